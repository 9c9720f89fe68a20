#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "convert.hpp"

PYBIND11_MODULE(imufusion, m) {
  m.doc() =
      "Real-time 3D scanning with a depth camera and an IMU: IMU-seeded ICP and TSDF fusion on "
      "Vulkan. Arrays are numpy; units metres, seconds, rad/s, m/s^2; poses are 4x4 T_a_b "
      "(b-coordinates into a). Failing calls raise imufusion.Error; wrong arrays ValueError.";
  m.attr("__version__") = IMUFUSION_VERSION;
  imufusion::python::register_error(m);
  imufusion::python::bind_types(m);
  imufusion::python::bind_config(m);
  imufusion::python::bind_scanner(m);
  imufusion::python::bind_sequence(m);
  imufusion::python::bind_mesh_io(m);
}
