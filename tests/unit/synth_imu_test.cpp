// The synthetic IMU: noiseless gyro integrates to the ground-truth rotation, bias and noise are
// what was asked for, the accelerometer measures specific force in the phone frame.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "imufusion/synth.hpp"

namespace imufusion::synth {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

Eigen::Matrix3d R_world_imu(const CameraMotion& motion, const Eigen::Isometry3d& T_camera_imu,
                            double t) {
  return (motion.pose_at(t) * T_camera_imu).linear();
}

TEST(SynthImu, MountingIsAPhoneFrameWithSmallError) {
  const Eigen::Isometry3d T = default_T_camera_imu();
  EXPECT_NEAR((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  const Eigen::Matrix3d phone = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const double error = Eigen::AngleAxisd(phone.transpose() * T.linear()).angle();
  EXPECT_GT(error, 1.0 * kDeg);
  EXPECT_LT(error, 5.0 * kDeg);
  EXPECT_LT(T.translation().norm(), 0.05);
}

TEST(SynthImu, NoiselessGyroIntegratesToGroundTruthRotation) {
  ImuConfig config;
  config.noise = false;  // bias stays on and is removed below
  for (const SceneKind kind : {SceneKind::kRoom, SceneKind::kWall, SceneKind::kFast}) {
    const CameraMotion motion(kind, 21, 5.0);
    const ImuBias bias = draw_imu_bias(21);
    // Several 1 s windows, including the wall turn and fast bursts.
    for (const double t0 : {5.0, 6.2, 8.0, 11.0}) {
      const std::vector<ImuSample> s = generate_imu(motion, config, bias, t0, t0 + 1.0, 21);
      ASSERT_GE(s.size(), 195u);
      Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
      for (std::size_t i = 0; i + 1 < s.size(); ++i) {
        // Trapezoidal rule on the bias-corrected rate.
        const Eigen::Vector3d w = 0.5 * (s[i].gyro + s[i + 1].gyro) - bias.gyro;
        R = R * exp_so3(w * (s[i + 1].timestamp - s[i].timestamp));
      }
      const Eigen::Matrix3d truth =
          R_world_imu(motion, config.T_camera_imu, s.front().timestamp).transpose() *
          R_world_imu(motion, config.T_camera_imu, s.back().timestamp);
      const double error = Eigen::AngleAxisd(R.transpose() * truth).angle();
      EXPECT_LT(error, 0.1 * kDeg) << to_string(kind) << " t0 " << t0;
      // And the window really rotates, so the check has teeth.
      EXPECT_GT(Eigen::AngleAxisd(truth).angle(), 2.0 * kDeg) << to_string(kind) << " t0 " << t0;
    }
  }
}

TEST(SynthImu, BiasAndNoiseMatchTheConfiguration) {
  const CameraMotion motion(SceneKind::kRoom, 8);
  const ImuBias bias = draw_imu_bias(8);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(std::abs(bias.gyro[a]), 0.01);
    EXPECT_LE(std::abs(bias.gyro[a]), 0.02);
  }
  EXPECT_FALSE(bias.gyro.isApprox(draw_imu_bias(9).gyro));
  ImuConfig config;
  const std::vector<ImuSample> s = generate_imu(motion, config, bias, 0.0, 20.0, 8);
  const double n = static_cast<double>(s.size());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d asum = Eigen::Vector3d::Zero(), asum2 = Eigen::Vector3d::Zero();
  for (const ImuSample& sample : s) {
    const Eigen::Vector3d e =
        sample.gyro - true_gyro(motion, config.T_camera_imu, sample.timestamp);
    const Eigen::Vector3d ea =
        sample.accel - true_accel(motion, config.T_camera_imu, sample.timestamp);
    sum += e;
    sum2 += e.cwiseProduct(e);
    asum += ea;
    asum2 += ea.cwiseProduct(ea);
  }
  const double gyro_sigma = config.gyro_noise_density * std::sqrt(config.rate_hz);
  const double accel_sigma = config.accel_noise_density * std::sqrt(config.rate_hz);
  for (int a = 0; a < 3; ++a) {
    const double mean = sum[a] / n;
    const double std = std::sqrt(sum2[a] / n - mean * mean);
    EXPECT_NEAR(mean, bias.gyro[a], 5.0 * gyro_sigma / std::sqrt(n));  // ~0.002 rad/s
    EXPECT_NEAR(std, gyro_sigma, 0.05 * gyro_sigma);
    const double amean = asum[a] / n;
    const double astd = std::sqrt(asum2[a] / n - amean * amean);
    EXPECT_NEAR(amean, bias.accel[a], 5.0 * accel_sigma / std::sqrt(n));
    EXPECT_NEAR(astd, accel_sigma, 0.05 * accel_sigma);
  }
}

TEST(SynthImu, TimestampsAreJitteredIncreasingAndCoverTheSpan) {
  const CameraMotion motion(SceneKind::kFast, 2, 100.0);
  ImuConfig config;
  const std::vector<ImuSample> s = generate_imu(motion, config, ImuBias{}, 99.9, 105.102, 2);
  ASSERT_EQ(s.size(), 1041u);  // 5.2 s at 200 Hz, both ends
  bool jittered = false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double nominal = 99.9 + static_cast<double>(i) * 0.005;
    EXPECT_LE(std::abs(s[i].timestamp - nominal), 0.0005 + 1e-6);
    jittered |= std::abs(s[i].timestamp - nominal) > 1e-4;
    if (i > 0) {
      EXPECT_GT(s[i].timestamp, s[i - 1].timestamp);
    }
  }
  EXPECT_TRUE(jittered);
  EXPECT_LT(s.front().timestamp, 100.0);
  EXPECT_GT(s.back().timestamp, 105.0);
}

TEST(SynthImu, AccelerometerReadsSpecificForceInThePhoneFrame) {
  ImuConfig config;
  config.noise = false;
  config.bias = false;
  for (const SceneKind kind : {SceneKind::kRoom, SceneKind::kWall}) {
    const CameraMotion motion(kind, 6);
    const std::vector<ImuSample> s = generate_imu(motion, config, ImuBias{}, 0.0, 20.0, 6);
    Eigen::Vector3d mean_world = Eigen::Vector3d::Zero();
    int rest_like = 0;
    for (const ImuSample& sample : s) {
      const Eigen::Matrix3d R = R_world_imu(motion, config.T_camera_imu, sample.timestamp);
      const Eigen::Vector3d f_world = R * sample.accel;
      mean_world += f_world;
      // Kinematic acceleration = f + g; where it is small the reading is gravity alone.
      if ((f_world + gravity_world()).norm() < 0.2) {
        ++rest_like;
        EXPECT_NEAR(sample.accel.norm(), 9.81, 0.2);
      }
    }
    mean_world /= static_cast<double>(s.size());
    // The mean of f = a - g over the span is (v_end - v_begin) / T + (0, 0, 9.81): the sign
    // convention (+9.81 up) and the lever arm are both in there.
    auto velocity = [&](double t) {
      const double h = 1e-4;
      return Eigen::Vector3d(((motion.pose_at(t + h) * config.T_camera_imu).translation() -
                              (motion.pose_at(t - h) * config.T_camera_imu).translation()) /
                             (2 * h));
    };
    const double span = s.back().timestamp - s.front().timestamp;
    const Eigen::Vector3d expected =
        (velocity(s.back().timestamp) - velocity(s.front().timestamp)) / span - gravity_world();
    EXPECT_LT((mean_world - expected).norm(), 0.005) << to_string(kind);
    EXPECT_GT(rest_like, 5) << to_string(kind);
  }
  // Facing the wall (camera level), the phone's +y axis points up: accel ~ (0, +9.81, 0).
  const CameraMotion wall(SceneKind::kWall, 6);
  const std::optional<TimeSpan> stretch = wall.wall_stretch();
  ASSERT_TRUE(stretch);
  const Eigen::Vector3d f =
      true_accel(wall, config.T_camera_imu, 0.5 * (stretch->begin + stretch->end));
  // Within the view sweep (pitch, roll a few degrees) plus the mounting error: < 10 degrees.
  EXPECT_GT(f.y() / f.norm(), std::cos(10.0 * kDeg));
}

TEST(SynthImu, SameSeedSameSamples) {
  const CameraMotion motion(SceneKind::kRoom, 4);
  const ImuConfig config;
  const ImuBias bias = draw_imu_bias(4);
  const std::vector<ImuSample> a = generate_imu(motion, config, bias, 0.0, 2.0, 4);
  const std::vector<ImuSample> b = generate_imu(motion, config, bias, 0.0, 2.0, 4);
  const std::vector<ImuSample> c = generate_imu(motion, config, bias, 0.0, 2.0, 5);
  ASSERT_EQ(a.size(), b.size());
  bool differs = false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].timestamp, b[i].timestamp);
    EXPECT_TRUE(a[i].gyro == b[i].gyro && a[i].accel == b[i].accel);
    differs |= a[i].gyro != c[i].gyro;
  }
  EXPECT_TRUE(differs);
}

}  // namespace
}  // namespace imufusion::synth
