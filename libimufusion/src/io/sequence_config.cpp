#include <cmath>
#include <cstdlib>

#include "imufusion/presets.hpp"
#include "imufusion/sequence.hpp"
#include "io/sequence_check.hpp"

namespace imufusion {

namespace {

// A whole-string finite number, or nothing.
std::optional<double> parse_number(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace

Result<ReconstructorConfig> sequence_config(SensorPreset sensor, const SequenceReader& sequence,
                                            bool with_imu) {
  const SequenceInfo& info = sequence.info();
  if (!sequence.intrinsics()) {
    return make_error(ErrorCode::kInvalidArgument, (info.directory / "calibration.txt").string() +
                                                       " is missing and no intrinsics were given");
  }
  Intrinsics k = *sequence.intrinsics();
  k.width = info.width;
  k.height = info.height;
  // An imu.txt on another clock than the frames covers none of them: it cannot aid the scan.
  const bool imu_usable =
      sequence.has_imu() && io::frames_within_imu(sequence.imu(), sequence.timestamps()) > 0;
  ReconstructorConfig config = preset_config(sensor, k, with_imu && imu_usable);
  apply_sequence_calibration(sequence, config);
  return config;
}

void apply_sequence_calibration(const SequenceReader& sequence, ReconstructorConfig& config) {
  const SequenceInfo& info = sequence.info();
  if (info.has_imu_to_camera) {
    config.inertial.T_camera_imu = info.T_camera_imu;
    config.inertial.T_camera_imu_known = true;
  }
  if (auto noise = info.info.find("gyro_noise_density"); noise != info.info.end()) {
    if (auto v = parse_number(noise->second); v && *v > 0) config.inertial.gyro_noise_density = *v;
  }
}

}  // namespace imufusion
