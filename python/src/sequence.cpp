#include "imufusion/sequence.hpp"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <memory>

#include "bindings.hpp"
#include "convert.hpp"

namespace imufusion::python {

namespace {

// One frame of a sequence as arrays.
struct PyFrame {
  std::size_t index = 0;
  double timestamp = 0;
  py::array depth;         // (H, W) uint16
  double depth_scale = 0;  // raw units per metre
  py::object color;        // (H, W, 3) uint8, or None
  double color_timestamp = 0;
  py::array imu;  // (N, 7) float64
};

PyFrame to_python(Frame frame) {
  PyFrame f;
  f.index = frame.index;
  f.timestamp = frame.timestamp;
  f.depth = depth_to_array(frame.depth);
  f.depth_scale = frame.depth.depth_scale;
  f.color = frame.color ? py::object(color_to_array(*frame.color)) : py::object(py::none());
  f.color_timestamp = frame.color_timestamp;
  f.imu = imu_to_array(frame.imu);
  return f;
}

PyFrame next_frame(SequenceReader& self) {
  if (self.done()) throw py::stop_iteration();
  Result<Frame> frame = [&] {
    py::gil_scoped_release unlocked;
    return self.next();
  }();
  return to_python(unwrap(std::move(frame)));
}

void bind_frame(py::module_& m) {
  py::class_<PyFrame>(m, "Frame", "One depth frame of a sequence with its colour and IMU samples")
      .def_readonly("index", &PyFrame::index)
      .def_readonly("timestamp", &PyFrame::timestamp, "seconds")
      .def_readonly("depth", &PyFrame::depth, "(H, W) uint16, depth_scale units per metre")
      .def_readonly("depth_scale", &PyFrame::depth_scale)
      .def_readonly("color", &PyFrame::color, "(H, W, 3) uint8, or None")
      .def_readonly("color_timestamp", &PyFrame::color_timestamp)
      .def_readonly("imu", &PyFrame::imu,
                    "(N, 7) t gx gy gz ax ay az: the samples since the previous frame");
}

std::unique_ptr<SequenceReader> open_reader(const std::filesystem::path& directory,
                                            bool load_color) {
  SequenceOptions options;
  options.load_color = load_color;
  return std::make_unique<SequenceReader>(unwrap(SequenceReader::open(directory, options)));
}

void bind_reader(py::module_& m) {
  constexpr const char* kOpenDoc =
      "Opens and checks a sequence; raises imufusion.Error naming the file at fault";
  py::class_<SequenceReader>(m, "SequenceReader",
                             "A recorded sequence (FORMAT.md); iterating gives its Frames")
      .def(py::init(&open_reader), py::arg("directory"), py::arg("load_color") = true, kOpenDoc)
      .def_static("open", &open_reader, py::arg("directory"), py::arg("load_color") = true,
                  kOpenDoc)
      .def_property_readonly("directory",
                             [](const SequenceReader& s) { return s.info().directory; })
      .def_property_readonly("intrinsics", &SequenceReader::intrinsics, "Intrinsics or None")
      .def_property_readonly("width", [](const SequenceReader& s) { return s.info().width; })
      .def_property_readonly("height", [](const SequenceReader& s) { return s.info().height; })
      .def_property_readonly("depth_scale",
                             [](const SequenceReader& s) { return s.info().depth_scale; })
      .def_property_readonly(
          "info", [](const SequenceReader& s) { return s.info().info; },
          "info.txt as a dict of str")
      .def_property_readonly("has_imu", &SequenceReader::has_imu)
      .def_property_readonly(
          "imu", [](const SequenceReader& s) { return imu_to_array(s.imu()); },
          "(N, 7) every IMU sample")
      .def_property_readonly("has_imu_to_camera",
                             [](const SequenceReader& s) { return s.info().has_imu_to_camera; })
      .def_property_readonly(
          "T_camera_imu", [](const SequenceReader& s) { return pose_to_array(s.T_camera_imu()); },
          "4x4 IMU-to-camera (identity without imu_to_camera.txt)")
      .def_property_readonly("has_ground_truth", &SequenceReader::has_ground_truth)
      .def_property_readonly(
          "ground_truth",
          [](const SequenceReader& s) { return trajectory_to_array(s.ground_truth()); },
          "(N, 8) TUM rows")
      .def_property_readonly("frame_count", &SequenceReader::frame_count)
      .def_property_readonly("timestamps",
                             [](const SequenceReader& s) {
                               const std::vector<double> t = s.timestamps();
                               return py::array_t<double>(static_cast<py::ssize_t>(t.size()),
                                                          t.data());
                             })
      .def("__len__", &SequenceReader::frame_count)
      .def(
          "frame",
          [](const SequenceReader& s, std::size_t i) { return to_python(unwrap(s.frame(i))); },
          py::arg("index"), "Decodes frame `index` (the cursor of next() stays)")
      .def("next", &next_frame, "The frame at the cursor; StopIteration after the last")
      .def("__next__", &next_frame)
      .def(
          "__iter__", [](py::object self) { return self; }, "Frames from the cursor on")
      .def("seek", &SequenceReader::seek, py::arg("index"))
      .def_property_readonly("done", &SequenceReader::done);
}

void bind_writer(py::module_& m) {
  py::class_<SequenceWriter>(m, "SequenceWriter", "Writes a sequence in the FORMAT.md layout")
      .def(py::init([](const std::filesystem::path& directory, bool allow_existing) {
             SequenceWriter::Options options;
             options.allow_existing = allow_existing;
             return std::make_unique<SequenceWriter>(
                 unwrap(SequenceWriter::create(directory, options)));
           }),
           py::arg("directory"), py::arg("allow_existing") = false)
      .def(
          "add_depth",
          [](SequenceWriter& w, double t, const py::handle& depth, double depth_scale) {
            check(w.add_depth(t, depth_from_array(depth, depth_scale, "depth")));
          },
          py::arg("timestamp"), py::arg("depth"), py::arg("depth_scale") = kDefaultDepthScale)
      .def(
          "add_color",
          [](SequenceWriter& w, double t, const py::handle& color) {
            check(w.add_color(t, color_from_array(color, "color")));
          },
          py::arg("timestamp"), py::arg("color"))
      .def(
          "add_imu",
          [](SequenceWriter& w, const py::handle& samples) {
            for (const ImuSample& s : imu_from_object(samples, "imu")) check(w.add_imu(s));
          },
          py::arg("samples"), "(N, 7) t gx gy gz ax ay az, or a list of ImuSample")
      .def(
          "add_ground_truth",
          [](SequenceWriter& w, double t, const py::handle& pose) {
            check(w.add_ground_truth({t, pose_from_array(pose, "T_world_camera")}));
          },
          py::arg("timestamp"), py::arg("T_world_camera"))
      .def("set_intrinsics",
           [](SequenceWriter& w, const Intrinsics& k) { check(w.set_intrinsics(k)); })
      .def("set_T_camera_imu",
           [](SequenceWriter& w, const py::handle& pose) {
             check(w.set_T_camera_imu(pose_from_array(pose, "T_camera_imu")));
           })
      .def("set_info", [](SequenceWriter& w, const std::string& key,
                          const std::string& value) { check(w.set_info(key, value)); })
      .def(
          "finish", [](SequenceWriter& w) { check(w.finish()); }, "Writes the index and text files")
      .def_property_readonly("directory", &SequenceWriter::directory);
}

}  // namespace

void bind_sequence(py::module_& m) {
  bind_frame(m);
  bind_reader(m);
  bind_writer(m);
}

}  // namespace imufusion::python
