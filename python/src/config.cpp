#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/sequence.hpp"

namespace imufusion::python {

namespace {

// A 4x4 numpy property over an Isometry3d member.
template <typename Class>
void pose_property(py::class_<Class>& c, const char* name, Eigen::Isometry3d Class::*member,
                   const char* doc) {
  c.def_property(
      name, [member](const Class& self) { return pose_to_array(self.*member); },
      [member, name](Class& self, const py::handle& value) {
        self.*member = pose_from_array(value, name);
      },
      doc);
}

void bind_parts(py::module_& m) {
  py::class_<PreprocessConfig>(m, "PreprocessConfig")
      .def_readwrite("levels", &PreprocessConfig::levels, "pyramid levels (default 3)")
      .def_readwrite("min_depth", &PreprocessConfig::min_depth, "metres (default 0.3)")
      .def_readwrite("max_depth", &PreprocessConfig::max_depth, "metres (default 5)")
      .def_readwrite("bilateral_sigma_depth", &PreprocessConfig::bilateral_sigma_depth,
                     "metres (default 0.03)");
  py::class_<DepthNoiseModel>(m, "DepthNoiseModel",
                              "the sensor's axial noise sigma(z) = a + b (z - z0)^2, metres")
      .def(py::init<>())
      .def_readwrite("a", &DepthNoiseModel::a, "metres (default 0.0012)")
      .def_readwrite("b", &DepthNoiseModel::b, "1/metre (default 0.0019)")
      .def_readwrite("z0", &DepthNoiseModel::z0, "metres (default 0.4)");
  py::class_<IcpPhotometricConfig>(m, "IcpPhotometricConfig",
                                   "ICP's photometric term on frames with colour")
      .def(py::init<>())
      .def_readwrite("weight", &IcpPhotometricConfig::weight,
                     "against the depth term, each by its own residual (default 1; 0: off)")
      .def_readwrite("huber_sigmas", &IcpPhotometricConfig::huber_sigmas,
                     "Huber threshold in RMS residuals (default 1.345)")
      .def_readwrite("initial_huber", &IcpPhotometricConfig::initial_huber,
                     "Huber threshold before a residual is known, intensity (default 0.1)")
      .def_readwrite("pixel_step", &IcpPhotometricConfig::pixel_step,
                     "every Nth pixel in x and y, each weighed as N^2 pixels (default 2)")
      .def_readwrite("min_sigma", &IcpPhotometricConfig::min_sigma,
                     "the camera's least intensity noise, 1 sigma (default 0.02)");
  py::class_<IcpConfig>(m, "IcpConfig")
      .def_readwrite("max_total_iterations", &IcpConfig::max_total_iterations,
                     "Gauss-Newton steps per frame while tracking")
      .def_readwrite("max_unsettled_iterations", &IcpConfig::max_unsettled_iterations,
                     "steps in all while a step still moves the pose by more than settled_chi2")
      .def_readwrite("settled_chi2", &IcpConfig::settled_chi2,
                     "chi^2 of a step under ICP's own covariance that counts as settled")
      .def_readwrite("iterations_per_level", &IcpConfig::iterations_per_level,
                     "steps allowed per pyramid level, level 0 (full size) first")
      .def_readwrite("max_distance", &IcpConfig::max_distance, "m per level")
      .def_readwrite("max_normal_angle_deg", &IcpConfig::max_normal_angle_deg, "deg per level")
      .def_readwrite("depth_noise", &IcpConfig::depth_noise, "the sensor's DepthNoiseModel")
      .def_readwrite("photometric", &IcpConfig::photometric, "the IcpPhotometricConfig");
  py::class_<VolumeConfig>(m, "VolumeConfig")
      .def_readwrite("voxel_size", &VolumeConfig::voxel_size, "metres (default 0.01)")
      .def_readwrite("truncation_voxels", &VolumeConfig::truncation_voxels, "default 4")
      .def_readwrite("max_weight", &VolumeConfig::max_weight, "observations (default 128)")
      .def_readwrite("initial_blocks", &VolumeConfig::initial_blocks,
                     "blocks the pool holds at first; it grows to block_capacity")
      .def_readwrite("block_capacity", &VolumeConfig::block_capacity,
                     "8^3-voxel blocks the pool may hold, 4 KiB each")
      .def_readwrite("hash_slots", &VolumeConfig::hash_slots, "a power of two above the capacity");
  py::class_<TrackingConfig>(m, "TrackingConfig")
      .def_readwrite("recovery_frames", &TrackingConfig::recovery_frames,
                     "reliable frames after a loss before fusion resumes (default 3)")
      .def_readwrite("relocalized_recovery_frames", &TrackingConfig::relocalized_recovery_frames,
                     "the same after a loss the relocalization search ended (default 1)")
      .def_readwrite("constant_velocity_pairs", &TrackingConfig::constant_velocity_pairs);
  py::class_<InertialConfig> inertial(m, "InertialConfig");
  pose_property(inertial, "T_camera_imu", &InertialConfig::T_camera_imu,
                "4x4: maps IMU coordinates into camera coordinates");
  inertial
      .def_readwrite("T_camera_imu_known", &InertialConfig::T_camera_imu_known,
                     "False: the mounting rotation is estimated online")
      .def_readwrite("estimate_gyro_bias", &InertialConfig::estimate_gyro_bias)
      .def_property(
          "initial_gyro_bias",
          [](const InertialConfig& c) { return vector3_to_array(c.initial_gyro_bias); },
          [](InertialConfig& c, const py::handle& v) {
            c.initial_gyro_bias = vector3_from_object(v, "initial_gyro_bias");
          },
          "(3,) rad/s, IMU frame")
      .def_readwrite("gyro_noise_density", &InertialConfig::gyro_noise_density,
                     "rad/s/sqrt(Hz) (default 0.003)")
      .def_readwrite("translation", &InertialConfig::translation);
  py::class_<ImuAidConfig>(m, "ImuAidConfig")
      .def_readwrite("enabled", &ImuAidConfig::enabled, "False: ICP alone, no inertial data")
      .def_readwrite("partial_icp", &ImuAidConfig::partial_icp)
      .def_readwrite("seed_reach_pixels", &ImuAidConfig::seed_reach_pixels);
  py::class_<DeviceOptions>(m, "DeviceOptions")
      .def_readwrite("selector", &DeviceOptions::selector,
                     "'' (IMUFUSION_DEVICE, else the best device), an index or part of a name")
      .def_readwrite("validation", &DeviceOptions::validation, "Khronos validation layer");
}

void bind_reconstructor_config(py::module_& m) {
  py::class_<ReconstructorConfig> c(m, "ReconstructorConfig",
                                    "The scanner's settings; start from preset_config()");
  c.def(py::init<>())
      .def_readwrite("intrinsics", &ReconstructorConfig::intrinsics, "of the depth camera")
      .def_readwrite("preprocess", &ReconstructorConfig::preprocess)
      .def_readwrite("icp", &ReconstructorConfig::icp)
      .def_readwrite("volume", &ReconstructorConfig::volume)
      .def_readwrite("tracking", &ReconstructorConfig::tracking)
      .def_readwrite("inertial", &ReconstructorConfig::inertial)
      .def_readwrite("imu", &ReconstructorConfig::imu)
      .def_readwrite("device", &ReconstructorConfig::device)
      .def_readwrite("tracking_level", &ReconstructorConfig::tracking_level,
                     "pyramid level of ICP and the raycast; -1: by device")
      .def_readwrite("reference_frames", &ReconstructorConfig::reference_frames,
                     "frames one model raycast serves as ICP's reference; 0: by device")
      .def_readwrite("reference_motion_pixels", &ReconstructorConfig::reference_motion_pixels,
                     "px of image motion since the reference from which a frame raycasts again")
      .def(
          "validate", [](const ReconstructorConfig& self) { check(self.validate()); },
          "Raises imufusion.Error naming the first setting out of range");
  pose_property(c, "initial_pose", &ReconstructorConfig::initial_pose,
                "4x4 T_world_camera of the first frame (m)");
}

}  // namespace

void bind_config(py::module_& m) {
  bind_parts(m);
  bind_reconstructor_config(m);
  m.def("preset_config", &preset_config, py::arg("sensor"), py::arg("intrinsics"),
        py::arg("with_imu") = true,
        "The scanner's configuration for a class of sensor; the camera-IMU mounting is "
        "estimated unless config.inertial.T_camera_imu(_known) are set");
  m.def(
      "sequence_config",
      [](SensorPreset sensor, const SequenceReader& sequence, bool with_imu) {
        return unwrap(sequence_config(sensor, sequence, with_imu));
      },
      py::arg("sensor"), py::arg("sequence"), py::arg("with_imu") = true,
      "preset_config for a recorded sequence as imufusion-scan configures it: its intrinsics, "
      "its IMU when it covers the frames, imu_to_camera.txt and info.txt's gyro_noise_density");
  m.attr("PRESET_ICP_ITERATIONS_WITH_IMU") = kPresetIcpIterationsWithImu;
  m.attr("PRESET_ICP_ITERATIONS_WITHOUT_IMU") = kPresetIcpIterationsWithoutImu;
}

}  // namespace imufusion::python
