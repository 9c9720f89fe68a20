#pragma once
// The scanner's settings per class of depth sensor: one set of defaults that the library, the
// tools (imufusion-scan, imufusion-fuse) and the Python bindings share. The measurements behind
// each preset: bench/README.md, "Sensor presets" and "The phone-ToF preset".

#include <optional>
#include <string_view>

#include "imufusion/reconstructor.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

class SequenceReader;

/// Classes of depth sensor with measured defaults.
enum class SensorPreset {
  /// 640x480-class structured light or ToF at 30 Hz, 0.3-5 m (Kinect v1, Asus Xtion, the TUM
  /// RGB-D recordings): the sensor modelled by the project's generator and the independent
  /// renderer, and recorded in TUM fr1_xyz.
  kKinect,
  /// A phone time-of-flight module of 2019-2021 phones, 240x180-class at 30 Hz, 0.2-4 m, noise
  /// about 1 % of the depth, flying pixels at depth edges (Sony IMX316 class, Android DEPTH16):
  /// measured on the project's generator's model of one (synth::SensorKind::kPhoneToF) only.
  kPhoneToF,
};

/// "kinect" for kKinect, "phone-tof" for kPhoneToF.
const char* to_string(SensorPreset sensor);
/// The preset named `name` (as to_string writes it), or nothing.
std::optional<SensorPreset> parse_sensor_preset(std::string_view name);

/// The scanner's configuration for `sensor` with the depth camera's `intrinsics` (frames must
/// have their size); kPhoneToF differs from kKinect in the depth range (0.2-4 m), the depth noise
/// model (icp.depth_noise) and the voxel size (bench/README.md, "The phone-ToF preset"). With
/// an IMU (`with_imu`) ICP starts from the gyro's rotation and takes at most 2 Gauss-Newton steps
/// per frame; without, ICP alone takes up to 30. The camera-IMU mounting is left unknown (the
/// scanner estimates its rotation): set inertial.T_camera_imu and inertial.T_camera_imu_known
/// when it is known.
ReconstructorConfig preset_config(SensorPreset sensor, const Intrinsics& intrinsics, bool with_imu);

/// preset_config for a recorded sequence, as imufusion-scan scans one: its intrinsics with the
/// depth images' size; the IMU when `with_imu`, the sequence has imu.txt and its samples span at
/// least one depth frame; imu_to_camera.txt, when present, as the known mounting (else estimated);
/// info.txt's gyro_noise_density (rad/s/sqrt(Hz)) when it is a positive number. Fails
/// (kInvalidArgument) when the sequence has no intrinsics (no calibration.txt and none given).
Result<ReconstructorConfig> sequence_config(SensorPreset sensor, const SequenceReader& sequence,
                                            bool with_imu = true);
/// The part of sequence_config that a recording's calibration gives: imu_to_camera.txt as the
/// known mounting (left as it is when absent) and info.txt's gyro_noise_density.
void apply_sequence_calibration(const SequenceReader& sequence, ReconstructorConfig& config);

/// Gauss-Newton steps per frame at most in the presets, with and without an IMU (the paper's
/// comparison: one to two with the gyro's seed against up to 30 without).
inline constexpr int kPresetIcpIterationsWithImu = 2;
inline constexpr int kPresetIcpIterationsWithoutImu = 30;

}  // namespace imufusion
