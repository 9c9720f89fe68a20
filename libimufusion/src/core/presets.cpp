#include "imufusion/presets.hpp"

namespace imufusion {

const char* to_string(SensorPreset sensor) {
  switch (sensor) {
    case SensorPreset::kKinect:
      return "kinect";
  }
  return "unknown";
}

std::optional<SensorPreset> parse_sensor_preset(std::string_view name) {
  if (name == "kinect") return SensorPreset::kKinect;
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
  }
  config.imu.enabled = with_imu;
  // An app that does not know its IMU's mounting gets it estimated rather than assumed.
  config.inertial.T_camera_imu_known = false;
  config.icp.max_total_iterations =
      with_imu ? kPresetIcpIterationsWithImu : kPresetIcpIterationsWithoutImu;
  return config;
}

}  // namespace imufusion
