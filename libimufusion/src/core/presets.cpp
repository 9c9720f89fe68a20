#include "imufusion/presets.hpp"

namespace imufusion {

namespace {

/// The phone ToF class's settings over the Kinect ones (bench/README.md, "The phone-ToF preset").
void apply_phone_tof(ReconstructorConfig& config) {
  // The sensor's range: nothing nearer than 0.2 m or farther than 4 m is measured.
  config.preprocess.min_depth = 0.2f;
  config.preprocess.max_depth = 4.0f;
  // The sensor's noise, 1 % of z, as sigma(z) = a + b (z - z0)^2: within 15 % over 0.8-4 m.
  config.icp.depth_noise = DepthNoiseModel{0.0033, 0.00165, -1.0};
  config.volume.voxel_size = 0.02f;  // m: 2 cm scored best of 1, 1.5, 2 and 2.5 cm
  // ICP on the depth alone: 2 cm voxels hold the colour too coarsely for the photometric term
  // (bench/README.md, "The photometric term on by default").
  config.icp.photometric.weight = 0;
}

}  // namespace

const char* to_string(SensorPreset sensor) {
  switch (sensor) {
    case SensorPreset::kKinect:
      return "kinect";
    case SensorPreset::kPhoneToF:
      return "phone-tof";
  }
  return "unknown";
}

std::optional<SensorPreset> parse_sensor_preset(std::string_view name) {
  for (const SensorPreset sensor : {SensorPreset::kKinect, SensorPreset::kPhoneToF}) {
    if (name == to_string(sensor)) return sensor;
  }
  return std::nullopt;
}

ReconstructorConfig preset_config(SensorPreset sensor, const Intrinsics& intrinsics,
                                  bool with_imu) {
  ReconstructorConfig config;
  config.intrinsics = intrinsics;
  switch (sensor) {
    case SensorPreset::kKinect:
      // The library's member defaults are the Kinect class's (bench/README.md, "Sensor presets").
      break;
    case SensorPreset::kPhoneToF:
      apply_phone_tof(config);
      break;
  }
  config.imu.enabled = with_imu;
  // An app that does not know its IMU's mounting gets it estimated rather than assumed.
  config.inertial.T_camera_imu_known = false;
  config.icp.max_total_iterations =
      with_imu ? kPresetIcpIterationsWithImu : kPresetIcpIterationsWithoutImu;
  return config;
}

}  // namespace imufusion
