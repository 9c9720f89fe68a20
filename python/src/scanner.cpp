#include <pybind11/stl.h>

#include <memory>
#include <optional>

#include "bindings.hpp"
#include "convert.hpp"
#include "imufusion/reconstructor.hpp"

namespace imufusion::python {

namespace {

// The images and IMU samples of one frame, checked against the scanner's camera.
// The views read the numpy arrays they hold, which outlive the call that releases the GIL.
struct FrameInput {
  ArrayView<DepthView> depth;
  std::optional<ArrayView<ColorView>> color;
  std::vector<ImuSample> imu;

  ColorInput color_input() const { return color ? ColorInput(color->view) : ColorInput(); }
};

FrameInput frame_input(const Reconstructor& scanner, const py::handle& depth,
                       const py::handle& color, const py::handle& imu, double depth_scale) {
  FrameInput in{depth_view_of_array(depth, depth_scale, "depth"), std::nullopt,
                imu_from_object(imu, "imu")};
  const Intrinsics& k = scanner.config().intrinsics;
  const std::string size = std::to_string(k.height) + ", " + std::to_string(k.width);
  if (in.depth.view.width != k.width || in.depth.view.height != k.height)
    throw py::value_error("depth: expected shape (" + size + ") (the intrinsics' size), got " +
                          describe_array(depth));
  if (!color.is_none()) {
    in.color = color_view_of_array(color, "color");
    if (in.color->view.width != k.width || in.color->view.height != k.height)
      throw py::value_error("color: expected shape (" + size + ", 3) (the intrinsics' size), got " +
                            describe_array(color));
  }
  return in;
}

void bind_frame_result(py::module_& m) {
  py::class_<IcpQuality>(m, "IcpQuality", "ICP's figures for one frame (icp.hpp)")
      .def_readonly("iterations", &IcpQuality::iterations, "Gauss-Newton steps, all levels")
      .def_readonly("inliers", &IcpQuality::inliers)
      .def_readonly("inlier_fraction", &IcpQuality::inlier_fraction)
      .def_readonly("pixel_fraction", &IcpQuality::pixel_fraction)
      .def_readonly("covered_fraction", &IcpQuality::covered_fraction)
      .def_readonly("covered_inlier_fraction", &IcpQuality::covered_inlier_fraction)
      .def_readonly("residual_per_weight", &IcpQuality::residual_per_weight, "m^2")
      .def_readonly("condition", &IcpQuality::condition, "kappa of A^T A")
      .def_readonly("converged", &IcpQuality::converged)
      .def_readonly("constrained_directions", &IcpQuality::constrained_directions);
  py::class_<FrameResult>(m, "FrameResult", "What the scanner did with one frame")
      .def_readonly("index", &FrameResult::index)
      .def_readonly("timestamp", &FrameResult::timestamp, "seconds")
      .def_property_readonly(
          "T_world_camera", [](const FrameResult& f) { return pose_to_array(f.T_world_camera); },
          "4x4 camera-to-world pose, metres")
      .def_readonly("status", &FrameResult::status)
      .def_readonly("source", &FrameResult::source, "the pose's source")
      .def_readonly("fused", &FrameResult::fused)
      .def_readonly("recovered", &FrameResult::recovered, "this frame ended a loss")
      .def_readonly("relocalized", &FrameResult::relocalized)
      .def_readonly("retracked", &FrameResult::retracked)
      .def_readonly("new_reference", &FrameResult::new_reference)
      .def_readonly("icp_ran", &FrameResult::icp_ran)
      .def_property_readonly("icp_reliable", [](const FrameResult& f) { return f.icp.reliable(); })
      .def_property_readonly("icp_iterations",
                             [](const FrameResult& f) { return f.icp.quality.iterations; })
      .def_property_readonly("icp_quality", [](const FrameResult& f) { return f.icp.quality; })
      .def_property_readonly(
          "icp_reason", [](const FrameResult& f) { return f.icp.reason; },
          "why ICP was unreliable, '' when reliable")
      .def_property_readonly("total_ms", [](const FrameResult& f) { return f.timings.total_ms; })
      .def("__repr__", [](const FrameResult& f) {
        return "FrameResult(index=" + std::to_string(f.index) + ", status=" + to_string(f.status) +
               ", source=" + to_string(f.source) + ", fused=" + (f.fused ? "True" : "False") + ")";
      });
  py::class_<RaycastImages>(m, "RaycastImages", "The model seen from a pose")
      .def_property_readonly(
          "shaded", [](const RaycastImages& r) { return color_to_array(r.shaded); },
          "(H, W, 3) uint8, Lambertian shading, light at the camera")
      .def_property_readonly(
          "color", [](const RaycastImages& r) { return color_to_array(r.color); },
          "(H, W, 3) uint8 fused colour, black where never coloured")
      .def_property_readonly(
          "vertices", [](const RaycastImages& r) { return vec4_to_array(r.vertices); },
          "(H, W, 4) float32 camera-frame points (m), w = 1 where hit")
      .def_property_readonly(
          "normals", [](const RaycastImages& r) { return vec4_to_array(r.normals); },
          "(H, W, 4) float32 camera-frame unit normals, w = 1 where valid");
}

Result<FrameResult> track(Reconstructor& self, double t, const FrameInput& in) {
  py::gil_scoped_release unlocked;
  return self.track_and_fuse(t, in.depth.view, in.color_input(), in.imu);
}

void bind_frames(py::class_<Reconstructor>& c) {
  c.def(
       "track_and_fuse",
       [](Reconstructor& self, double t, const py::handle& depth, const py::handle& color,
          const py::handle& imu, double depth_scale) {
         const FrameInput in = frame_input(self, depth, color, imu, depth_scale);
         return unwrap(track(self, t, in));
       },
       py::arg("timestamp"), py::arg("depth"), py::arg("color") = py::none(),
       py::arg("imu") = py::none(), py::arg("depth_scale") = kDefaultDepthScale,
       "Tracks a depth frame (uint16 raw units, depth_scale per metre, or float32 metres, not "
       "quantized; (H, W), read in place, rows may be strided) with its colour ((H, W, 3) uint8 or "
       "None) and the IMU samples since the previous frame "
       "((N, 7) t gx gy gz ax ay az, or ImuSamples), and fuses it when tracking is reliable")
      .def(
          "fuse_with_pose",
          [](Reconstructor& self, double t, const py::handle& depth, const py::handle& color,
             const py::handle& pose, const py::handle& imu, double depth_scale) {
            const FrameInput in = frame_input(self, depth, color, imu, depth_scale);
            const Eigen::Isometry3d T = pose_from_array(pose, "T_world_camera");
            py::gil_scoped_release unlocked;
            return unwrap(self.fuse_with_pose(t, in.depth.view, in.color_input(), T, in.imu));
          },
          py::arg("timestamp"), py::arg("depth"), py::arg("color"), py::arg("T_world_camera"),
          py::arg("imu") = py::none(), py::arg("depth_scale") = kDefaultDepthScale,
          "Fuses a frame at a known 4x4 camera-to-world pose (no ICP)");
}

void bind_outputs(py::class_<Reconstructor>& c) {
  c.def(
       "finish",
       [](Reconstructor& self) {
         py::gil_scoped_release unlocked;
         return unwrap(self.finish());
       },
       "Ends the scan (settles a loss it ends in); returns the frames so placed")
      .def(
          "trajectory",
          [](const Reconstructor& self) { return trajectory_to_array(self.trajectory()); },
          "(N, 8) TUM rows t tx ty tz qx qy qz qw, camera-to-world, lost stretches re-estimated")
      .def(
          "extract_mesh",
          [](const Reconstructor& self, float min_weight, bool colors) {
            MeshOptions options;
            options.min_weight = min_weight;
            options.colors = colors;
            py::gil_scoped_release unlocked;
            return unwrap(self.extract_mesh(options));
          },
          py::arg("min_weight") = 1.0f, py::arg("colors") = true, "Marching cubes of the volume")
      .def(
          "raycast",
          [](Reconstructor& self, const py::handle& pose, std::optional<Intrinsics> k) {
            const Eigen::Isometry3d T = pose_from_array(pose, "T_world_camera");
            py::gil_scoped_release unlocked;
            return unwrap(self.raycast(T, k));
          },
          py::arg("T_world_camera"), py::arg("intrinsics") = py::none(),
          "The model seen from a 4x4 pose (default: the depth camera's intrinsics)")
      .def(
          "save",
          [](const Reconstructor& self, const std::string& path) {
            py::gil_scoped_release unlocked;
            check(self.save(path));
          },
          py::arg("path"), "Writes the scan so far to path (Reconstructor.load continues it)")
      .def(
          "reset", [](Reconstructor& self) { check(self.reset()); },
          "Empties the volume and forgets the trajectory");
}

}  // namespace

void bind_scanner(py::module_& m) {
  bind_frame_result(m);
  py::class_<Reconstructor> c(m, "Reconstructor", "The scanner: IMU-seeded ICP and TSDF fusion");
  const auto create = [](const ReconstructorConfig& config) {
    return std::make_unique<Reconstructor>(unwrap(Reconstructor::create(config)));
  };
  constexpr const char* kCreateDoc =
      "Creates the scanner on a Vulkan device; raises imufusion.Error";
  c.def(py::init(create), py::arg("config"), kCreateDoc)
      .def_static("create", create, py::arg("config"), kCreateDoc)
      .def_static(
          "load",
          [](const std::string& path, const std::string& device) {
            DeviceOptions options;
            options.selector = device;
            return std::make_unique<Reconstructor>(unwrap(Reconstructor::load(path, options)));
          },
          py::arg("path"), py::arg("device") = "",
          "The scan Reconstructor.save wrote, ready for its next frame; raises imufusion.Error")
      .def_property_readonly(
          "config", [](const Reconstructor& self) { return self.config(); },
          "a copy of the configuration")
      .def_property_readonly("device", [](const Reconstructor& self) { return self.device().name; })
      .def_property_readonly("tracking_level", &Reconstructor::tracking_level)
      .def_property_readonly("reference_frames", &Reconstructor::reference_frames)
      .def_property_readonly("allocated_blocks", &Reconstructor::allocated_blocks)
      .def_property_readonly("pool_blocks", &Reconstructor::pool_blocks)
      .def_property_readonly("pool_growths", &Reconstructor::pool_growths)
      .def_property_readonly("memory_bytes", &Reconstructor::memory_bytes);
  bind_frames(c);
  bind_outputs(c);
  bind_mesh_changes(c);
}

}  // namespace imufusion::python
