// Online gyro bias: converges to the true bias on synthetic motion with reliable tracking,
// ignores unreliable frames and refuses an inconsistent "reliable" pair.

#include <gtest/gtest.h>

#include "core/inertial_internal.hpp"
#include "inertial_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::kDeg;

InertialConfig config_for(const synth::ImuConfig& imu) {
  InertialConfig config;
  config.T_camera_imu = imu.T_camera_imu;
  config.gyro_noise_density = imu.gyro_noise_density;
  return config;
}

TEST(InertialBias, ConvergesToTheTrueBiasOnEveryScene) {
  // Tolerance: with 0.1 deg ICP error per 1/30 s pair, 20 s of pairs bound the bias to
  // ~0.1 deg / 33 ms / sqrt(600) = 2e-3 rad/s (1 sigma) per axis; true poses are exact here, so
  // the gyro noise (0.003 rad/s/sqrt(Hz) -> 7e-4 rad/s over 20 s) dominates. 2e-3 is ~3 sigma.
  for (const synth::SceneKind kind :
       {synth::SceneKind::kRoom, synth::SceneKind::kWall, synth::SceneKind::kFast}) {
    for (const std::uint64_t seed : {11u, 12u}) {
      const synth::CameraMotion motion(kind, seed);
      const synth::ImuBias bias = synth::draw_imu_bias(seed);
      test::RunOptions o;
      o.seed = seed;
      double error_after_1s = 0;
      o.after_frame = [&](const InertialNavigator& nav, int k, double) {
        if (k == 30) error_after_1s = (nav.status().gyro_bias - bias.gyro).norm();
      };
      const InertialNavigator nav = test::run_true_poses(motion, config_for(o.imu), o, bias);
      const InertialStatus st = nav.status();
      const double error = (st.gyro_bias - bias.gyro).norm();
      EXPECT_LT(error, 2e-3) << synth::to_string(kind) << " seed " << seed;
      EXPECT_LT(error, 0.25 * bias.gyro.norm()) << synth::to_string(kind);
      EXPECT_LT(error, error_after_1s) << synth::to_string(kind);
      EXPECT_EQ(st.bias_updates + st.bias_rejected, 600);
      EXPECT_LT(st.bias_rejected, 6);
      // Its own 1-sigma from the configured 0.1 deg ICP error: 0.1 deg / 33 ms / sqrt(600).
      EXPECT_LT(st.gyro_bias_sigma.maxCoeff(), 2.5e-3);
    }
  }
}

TEST(InertialBias, UnreliableFramesAndTheSwitchLeaveItAlone) {
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 4);
  const synth::ImuBias bias = synth::draw_imu_bias(4);
  test::RunOptions o;
  o.duration = 5.0;
  o.reliable = [](double) { return false; };
  InertialConfig config = config_for(o.imu);
  config.initial_gyro_bias = Eigen::Vector3d(0.001, 0.002, 0.003);
  EXPECT_TRUE(test::run_true_poses(motion, config, o, bias)
                  .status()
                  .gyro_bias.isApprox(config.initial_gyro_bias));
  o.reliable = [](double) { return true; };
  config.estimate_gyro_bias = false;
  const InertialStatus st = test::run_true_poses(motion, config, o, bias).status();
  EXPECT_TRUE(st.gyro_bias.isApprox(config.initial_gyro_bias));
  EXPECT_EQ(st.bias_updates, 0);
}

TEST(InertialBias, AnInconsistentReliablePairIsGatedOut) {
  inertial::SampleBuffer buffer(0.03, 0.04, 10.0);
  synth::ImuConfig imu;
  imu.T_camera_imu = Eigen::Isometry3d::Identity();
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 9);
  const synth::ImuBias bias = synth::draw_imu_bias(9);
  ASSERT_TRUE(buffer.append(synth::generate_imu(motion, imu, bias, 0.0, 4.0, 9)).ok());
  inertial::GyroBiasEstimator estimator(Eigen::Vector3d::Zero(), 0.03, 1e-4, 0.003, 0.1 * kDeg);
  for (int k = 0; k < 90; ++k) {
    const double ta = 0.5 + k / 30.0, tb = ta + 1.0 / 30.0;
    const Eigen::Matrix3d truth =
        motion.pose_at(ta).linear().transpose() * motion.pose_at(tb).linear();
    EXPECT_TRUE(estimator.update(
        tb, buffer.integrate(ta, tb, estimator.bias(), Eigen::Matrix3d::Identity()), truth,
        1.0 / 30.0, 0.0));
  }
  const Eigen::Vector3d before = estimator.bias();
  EXPECT_LT((before - bias.gyro).norm(), 0.3 * bias.gyro.norm());
  // ICP that "reliably" landed 3 deg off: refused, the estimate does not move.
  const double ta = 3.6, tb = ta + 1.0 / 30.0;
  const Eigen::Matrix3d wrong =
      motion.pose_at(ta).linear().transpose() * motion.pose_at(tb).linear() *
      Eigen::AngleAxisd(3.0 * kDeg, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_FALSE(
      estimator.update(tb, buffer.integrate(ta, tb, estimator.bias(), Eigen::Matrix3d::Identity()),
                       wrong, 1.0 / 30.0, 0.0));
  EXPECT_EQ(estimator.bias(), before);
  EXPECT_EQ(estimator.rejected(), 1);
}

}  // namespace
}  // namespace imufusion
