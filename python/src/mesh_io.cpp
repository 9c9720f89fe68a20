#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstring>
#include <optional>

#include "bindings.hpp"
#include "convert.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"

namespace imufusion::python {

namespace {

// (N, 3) of the 3-element rows of `rows` (Eigen vectors or std::arrays), or None when empty and
// `none_when_empty`.
template <typename T, typename Rows>
py::object rows_to_array(const Rows& rows, bool none_when_empty) {
  if (rows.empty() && none_when_empty) return py::none();
  py::array_t<T> array({static_cast<py::ssize_t>(rows.size()), py::ssize_t{3}});
  T* out = array.mutable_data();
  for (const auto& row : rows) {
    for (int i = 0; i < 3; ++i) *out++ = row[i];
  }
  return array;
}

void bind_mesh(py::module_& m) {
  py::class_<Mesh>(m, "Mesh", "A triangle mesh, world frame, metres")
      .def_property_readonly(
          "vertices", [](const Mesh& s) { return rows_to_array<float>(s.vertices, false); },
          "(N, 3) float32")
      .def_property_readonly(
          "triangles",
          [](const Mesh& s) { return rows_to_array<std::uint32_t>(s.triangles, false); },
          "(M, 3) uint32 vertex indices, counter-clockwise seen from outside")
      .def_property_readonly(
          "normals", [](const Mesh& s) { return rows_to_array<float>(s.normals, true); },
          "(N, 3) float32 unit normals, or None")
      .def_property_readonly(
          "colors", [](const Mesh& s) { return rows_to_array<std::uint8_t>(s.colors, true); },
          "(N, 3) uint8 RGB, or None")
      .def(
          "write_glb",
          [](const Mesh& s, const std::filesystem::path& p) { check(write_glb(p, s)); },
          py::arg("path"), "Binary glTF 2.0 (refused for an empty mesh)")
      .def(
          "write_ply",
          [](const Mesh& s, const std::filesystem::path& p) { check(write_ply(p, s)); },
          py::arg("path"), "Binary little-endian PLY")
      .def("__len__", [](const Mesh& s) { return s.triangles.size(); })
      .def("__repr__", [](const Mesh& s) {
        return "Mesh(" + std::to_string(s.vertices.size()) + " vertices, " +
               std::to_string(s.triangles.size()) + " triangles)";
      });
  m.def(
      "write_glb", [](const std::filesystem::path& p, const Mesh& s) { check(write_glb(p, s)); },
      py::arg("path"), py::arg("mesh"));
  m.def(
      "write_ply", [](const std::filesystem::path& p, const Mesh& s) { check(write_ply(p, s)); },
      py::arg("path"), py::arg("mesh"));
  m.def(
      "read_mesh", [](const std::filesystem::path& p) { return unwrap(read_mesh(p)); },
      py::arg("path"), "A .ply, .glb or .gltf mesh");
}

void bind_trajectories(py::module_& m) {
  m.def(
      "write_trajectory",
      [](const std::filesystem::path& path, const py::handle& trajectory,
         const std::string& comment) {
        check(write_trajectory(path, trajectory_from_object(trajectory, "trajectory"), comment));
      },
      py::arg("path"), py::arg("trajectory"), py::arg("comment") = "",
      "TUM lines from an (N, 8) array (t tx ty tz qx qy qz qw) or a list of (t, 4x4)");
  m.def(
      "read_trajectory",
      [](const std::filesystem::path& path) {
        return trajectory_to_array(unwrap(read_trajectory(path)));
      },
      py::arg("path"), "(N, 8) TUM rows t tx ty tz qx qy qz qw");
}

// The summary of synth::synthesize as a dict.
py::dict summary_dict(const synth::SynthSummary& s) {
  py::dict d;
  d["frames"] = s.frames;
  d["duration"] = s.duration;
  d["width"] = s.width;
  d["height"] = s.height;
  d["imu_samples"] = s.imu_samples;
  return d;
}

// The sensor named `name` (synth::parse_sensor_kind) or a ValueError.
synth::SensorKind sensor_kind(const std::string& name) {
  const auto kind = synth::parse_sensor_kind(name);
  if (!kind) throw py::value_error("sensor: expected 'kinect' or 'phone-tof', got '" + name + "'");
  return *kind;
}

void bind_synthesize(py::module_& m) {
  const synth::SynthConfig defaults;
  m.def(
      "synthesize",
      [](const std::filesystem::path& out_dir, const std::string& scene, int frames,
         std::uint64_t seed, std::optional<int> width, std::optional<int> height,
         std::optional<double> fps, bool color, bool depth_noise, bool imu_noise, bool overwrite,
         const std::string& sensor) {
        synth::SynthConfig c;
        const auto kind = synth::parse_scene_kind(scene);
        if (!kind)
          throw py::value_error("scene: expected 'room', 'wall' or 'fast', got '" + scene + "'");
        c.scene = *kind;
        c.sensor = sensor_kind(sensor);
        const synth::SensorFormat format = synth::sensor_format(c.sensor);
        c.frames = frames;
        c.seed = seed;
        c.width = width.value_or(format.width);
        c.height = height.value_or(format.height);
        c.fps = fps.value_or(format.fps);
        c.color = color;
        c.depth_noise = depth_noise;
        c.imu_noise = imu_noise;
        c.overwrite = overwrite;
        auto summary = [&] {
          py::gil_scoped_release unlocked;
          return synth::synthesize(c, out_dir);
        }();
        return summary_dict(unwrap(std::move(summary)));
      },
      py::arg("out_dir"), py::arg("scene") = "room", py::arg("frames") = defaults.frames,
      py::arg("seed") = defaults.seed, py::arg("width") = py::none(),
      py::arg("height") = py::none(), py::arg("fps") = py::none(),
      py::arg("color") = defaults.color, py::arg("depth_noise") = defaults.depth_noise,
      py::arg("imu_noise") = defaults.imu_noise, py::arg("overwrite") = defaults.overwrite,
      py::arg("sensor") = synth::to_string(defaults.sensor),
      "Renders a synthetic sequence (scene 'room', 'wall' or 'fast'; sensor 'kinect' or "
      "'phone-tof', whose size and fps are the defaults) with ground truth and IMU into out_dir; "
      "imufusion-scan's demo is synthesize(dir, 'room', frames=60)");
}

}  // namespace

void bind_mesh_io(py::module_& m) {
  bind_mesh(m);
  bind_trajectories(m);
  bind_synthesize(m);
}

}  // namespace imufusion::python
