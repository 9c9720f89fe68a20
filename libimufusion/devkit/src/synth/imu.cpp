// Phone-like IMU samples derived from the ground-truth camera motion.
//
// The IMU body is T_world_imu(t) = T_world_camera(t) * T_camera_imu. Angular velocity and linear
// acceleration come from central differences of that smooth pose (errors ~1e-9, far below any
// sensor noise), so a noiseless gyroscope integrates back to the ground-truth rotation.

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/so3.hpp"
#include "imufusion/synth.hpp"
#include "synth/random.hpp"

namespace imufusion::synth {

namespace {

constexpr double kRotationStep = 1e-4;  // seconds, central difference for angular velocity
constexpr double kPositionStep = 1e-3;  // seconds, second difference for acceleration

Eigen::Isometry3d imu_pose(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                           double t) {
  return motion.pose_at(t) * T_camera_imu;
}

}  // namespace

Eigen::Isometry3d default_T_camera_imu() {
  // Phone axes in camera axes: x right = camera x, y up = -camera y, z toward the user =
  // -camera z; then a mounting error of a few degrees about a skew axis.
  Eigen::Matrix3d phone;
  phone << 1, 0, 0,  //
      0, -1, 0,      //
      0, 0, -1;
  const double deg = std::numbers::pi / 180.0;
  const Eigen::Matrix3d mounting =
      Eigen::AngleAxisd(2.5 * deg, Eigen::Vector3d(0.6, -0.5, 0.62).normalized())
          .toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = phone * mounting;
  T.translation() = Eigen::Vector3d(0.025, -0.012, -0.008);  // lever arm, metres (camera frame)
  return T;
}

ImuBias draw_imu_bias(std::uint64_t seed) {
  Rng rng(mix_seed(seed, 303));
  ImuBias bias;
  for (int a = 0; a < 3; ++a) bias.gyro[a] = rng.sign() * rng.uniform(0.01, 0.02);
  for (int a = 0; a < 3; ++a) bias.accel[a] = rng.sign() * rng.uniform(0.02, 0.06);
  return bias;
}

Eigen::Vector3d true_gyro(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                          double t) {
  const Eigen::Matrix3d R0 = imu_pose(motion, T_camera_imu, t - kRotationStep).linear();
  const Eigen::Matrix3d R1 = imu_pose(motion, T_camera_imu, t + kRotationStep).linear();
  // Body-frame rate: R(t + h) = R(t - h) exp(2 h [w]x) to second order.
  return log_so3(R0.transpose() * R1) / (2.0 * kRotationStep);
}

Eigen::Vector3d true_accel(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                           double t) {
  const Eigen::Isometry3d T = imu_pose(motion, T_camera_imu, t);
  const Eigen::Vector3d p_prev = imu_pose(motion, T_camera_imu, t - kPositionStep).translation();
  const Eigen::Vector3d p_next = imu_pose(motion, T_camera_imu, t + kPositionStep).translation();
  const Eigen::Vector3d a_world =
      (p_next - 2.0 * T.translation() + p_prev) / (kPositionStep * kPositionStep);
  return T.linear().transpose() * (a_world - gravity_world());
}

std::vector<ImuSample> generate_imu(const CameraMotion& motion, const ImuConfig& config,
                                    const ImuBias& bias, double t_begin, double t_end,
                                    std::uint64_t seed) {
  std::vector<ImuSample> samples;
  if (!(config.rate_hz > 0.0) || !(t_end >= t_begin)) return samples;
  Rng rng(mix_seed(seed, 404));
  const double period = 1.0 / config.rate_hz;
  // White noise with density n (unit/sqrt(Hz)) sampled at rate r has standard deviation n sqrt(r).
  const double gyro_sigma = config.gyro_noise_density * std::sqrt(config.rate_hz);
  const double accel_sigma = config.accel_noise_density * std::sqrt(config.rate_hz);
  // Jitter below half a period keeps the stamps strictly increasing.
  const double jitter = std::min(config.timestamp_jitter, 0.45 * period);
  const auto count = static_cast<std::size_t>(std::floor((t_end - t_begin) / period)) + 1;
  samples.reserve(count);
  for (std::size_t k = 0; k < count; ++k) {
    // Draw every random number for every sample, so toggles do not shift later samples.
    const double dt = rng.uniform(-jitter, jitter);
    Eigen::Vector3d gyro_noise, accel_noise;
    for (int a = 0; a < 3; ++a) gyro_noise[a] = rng.normal();
    for (int a = 0; a < 3; ++a) accel_noise[a] = rng.normal();

    ImuSample s;
    // Stamps are whole microseconds, the precision of the text files.
    s.timestamp = std::round((t_begin + static_cast<double>(k) * period + dt) * 1e6) / 1e6;
    s.gyro = true_gyro(motion, config.T_camera_imu, s.timestamp);
    s.accel = true_accel(motion, config.T_camera_imu, s.timestamp);
    if (config.bias) {
      s.gyro += bias.gyro;
      s.accel += bias.accel;
    }
    if (config.noise) {
      s.gyro += gyro_sigma * gyro_noise;
      s.accel += accel_sigma * accel_noise;
    }
    samples.push_back(s);
  }
  return samples;
}

}  // namespace imufusion::synth
