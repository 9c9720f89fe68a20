#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <utility>
#include <vector>

#include "bindings.hpp"
#include "convert.hpp"
#include "imufusion/reconstructor.hpp"

namespace imufusion::python {

namespace {

py::array_t<std::int32_t> block_to_array(const Eigen::Vector3i& block) {  // (3,)
  py::array_t<std::int32_t> array(py::ssize_t{3});
  for (int i = 0; i < 3; ++i) array.mutable_data()[i] = block[i];
  return array;
}

py::array_t<std::int32_t> blocks_to_array(const std::vector<Eigen::Vector3i>& blocks) {  // (M, 3)
  py::array_t<std::int32_t> array({static_cast<py::ssize_t>(blocks.size()), py::ssize_t{3}});
  std::int32_t* out = array.mutable_data();
  for (const Eigen::Vector3i& block : blocks) {
    for (int i = 0; i < 3; ++i) *out++ = block[i];
  }
  return array;
}

}  // namespace

void bind_mesh_changes(py::class_<Reconstructor>& c) {
  c.def(
      "extract_mesh_changes",
      [](Reconstructor& self, float min_weight, bool colors) {
        MeshOptions options;
        options.min_weight = min_weight;
        options.colors = colors;
        MeshUpdate update;
        {
          py::gil_scoped_release unlocked;
          update = unwrap(self.extract_mesh_changes(options));
        }
        py::list changed;
        for (BlockMesh& piece : update.changed)
          changed.append(py::make_tuple(block_to_array(piece.block), std::move(piece.mesh)));
        return py::make_tuple(changed, blocks_to_array(update.removed));
      },
      py::arg("min_weight") = 1.0f, py::arg("colors") = true,
      "The mesh's pieces per 8^3-voxel block that changed since the previous call: (changed, "
      "removed), changed a list of (block (3,) int32, Mesh), removed an (M, 3) int32 array of "
      "blocks whose piece became empty. Everything on the first call, after reset() and when the "
      "options change");
}

}  // namespace imufusion::python
