#include "imufusion/types.hpp"

#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "imufusion/device.hpp"
#include "imufusion/inertial.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/tracking.hpp"

namespace imufusion::python {

namespace {

// str(enum) is the library's name for the value ("tracking", "dead_reckoning"), as in frames.csv.
template <typename Enum>
void name_values_as_library(py::enum_<Enum>& e) {
  // Replaces pybind11's __str__ ("PoseSource.ICP") rather than adding an overload after it.
  e.attr("__str__") =
      py::cpp_function([](Enum value) { return std::string(to_string(value)); }, py::is_method(e));
}

void bind_enums(py::module_& m) {
  py::enum_<SensorPreset> preset(m, "SensorPreset",
                                 "Classes of depth sensor with measured defaults: KINECT "
                                 "(640x480 structured light), PHONE_TOF (240x180 phone ToF)");
  preset.value("KINECT", SensorPreset::kKinect).value("PHONE_TOF", SensorPreset::kPhoneToF);
  name_values_as_library(preset);
  py::enum_<TrackingStatus> status(m, "TrackingStatus");
  status.value("TRACKING", TrackingStatus::kTracking)
      .value("LOST", TrackingStatus::kLost)
      .value("RECOVERING", TrackingStatus::kRecovering);
  name_values_as_library(status);
  py::enum_<PoseSource> source(m, "PoseSource", "Which estimate gave a frame its pose");
  source.value("INITIAL", PoseSource::kInitial)
      .value("ICP", PoseSource::kIcp)
      .value("ICP_PARTIAL", PoseSource::kIcpPartial)
      .value("DEAD_RECKONING", PoseSource::kDeadReckoning)
      .value("KNOWN", PoseSource::kKnown);
  name_values_as_library(source);
  py::enum_<TranslationModel> translation(m, "TranslationModel",
                                          "How the IMU predicts translation between frames");
  translation.value("NONE", TranslationModel::kNone)
      .value("CONSTANT_VELOCITY", TranslationModel::kConstantVelocity)
      .value("ACCELEROMETER", TranslationModel::kAccelerometer);
  name_values_as_library(translation);
}

void bind_intrinsics(py::module_& m) {
  py::class_<Intrinsics>(m, "Intrinsics",
                         "Pinhole intrinsics of the depth image, pixels (centres at integers)")
      .def(py::init([](double fx, double fy, double cx, double cy, int width, int height) {
             return Intrinsics{fx, fy, cx, cy, width, height};
           }),
           py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"), py::arg("width"),
           py::arg("height"))
      .def_readwrite("fx", &Intrinsics::fx)
      .def_readwrite("fy", &Intrinsics::fy)
      .def_readwrite("cx", &Intrinsics::cx)
      .def_readwrite("cy", &Intrinsics::cy)
      .def_readwrite("width", &Intrinsics::width)
      .def_readwrite("height", &Intrinsics::height)
      .def_readwrite("distortion", &Intrinsics::distortion,
                     "Lens distortion k1, k2, p1, p2, k3 (OpenCV's order); all 0: a pinhole")
      .def("at_level", &Intrinsics::at_level, py::arg("level"),
           "The intrinsics of the image downsampled by 2^level")
      .def("__repr__", [](const Intrinsics& k) {
        return "Intrinsics(fx=" + std::to_string(k.fx) + ", fy=" + std::to_string(k.fy) +
               ", cx=" + std::to_string(k.cx) + ", cy=" + std::to_string(k.cy) +
               ", width=" + std::to_string(k.width) + ", height=" + std::to_string(k.height) + ")";
      });
}

void bind_imu_sample(py::module_& m) {
  py::class_<ImuSample>(m, "ImuSample",
                        "One IMU sample in the IMU frame: gyro (rad/s), accelerometer (m/s^2)")
      .def(py::init([](double t, const py::handle& gyro, const py::handle& accel) {
             return ImuSample{t, vector3_from_object(gyro, "gyro"),
                              vector3_from_object(accel, "accel")};
           }),
           py::arg("timestamp"), py::arg("gyro"), py::arg("accel"))
      .def_readwrite("timestamp", &ImuSample::timestamp, "seconds")
      .def_property(
          "gyro", [](const ImuSample& s) { return vector3_to_array(s.gyro); },
          [](ImuSample& s, const py::handle& v) { s.gyro = vector3_from_object(v, "gyro"); },
          "(3,) rad/s")
      .def_property(
          "accel", [](const ImuSample& s) { return vector3_to_array(s.accel); },
          [](ImuSample& s, const py::handle& v) { s.accel = vector3_from_object(v, "accel"); },
          "(3,) m/s^2")
      .def("__repr__", [](const ImuSample& s) {
        return "ImuSample(timestamp=" + std::to_string(s.timestamp) + ")";
      });
}

}  // namespace

void bind_types(py::module_& m) {
  bind_enums(m);
  bind_intrinsics(m);
  bind_imu_sample(m);
  m.def(
      "list_devices",
      [] {
        py::list devices;
        for (const DeviceInfo& d : unwrap(list_devices())) {
          py::dict info;
          info["index"] = d.index;
          info["name"] = d.name;
          info["type"] = to_string(d.type);
          info["driver"] = d.driver;
          devices.append(info);
        }
        return devices;
      },
      "The Vulkan devices: dicts of index, name, type and driver");
}

}  // namespace imufusion::python
