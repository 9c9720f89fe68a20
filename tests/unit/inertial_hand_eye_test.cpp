// Camera-IMU rotation from rotation pairs: recovered on synthetic motion with the default phone
// mounting (180 deg from the camera frame plus a few degrees of mounting error), never used
// while it is ill-conditioned.

#include <gtest/gtest.h>

#include <random>

#include "core/inertial_internal.hpp"
#include "inertial_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::kDeg;

double rotation_deg(const Eigen::Matrix3d& R) { return test::rotation_angle(R) / kDeg; }

TEST(InertialHandEye, RecoversTheDefaultMountingOnline) {
  const Eigen::Matrix3d truth = synth::default_T_camera_imu().linear();
  for (const synth::SceneKind kind : {synth::SceneKind::kRoom, synth::SceneKind::kFast}) {
    for (const std::uint64_t seed : {21u, 22u}) {
      const synth::CameraMotion motion(kind, seed);
      const synth::ImuBias bias = synth::draw_imu_bias(seed);
      InertialConfig config;
      config.T_camera_imu_known = false;  // the guess (identity) is 180 deg off
      test::RunOptions o;
      o.seed = seed;
      int switched_at = -1, seeded_rotation_before_switch = 0;
      o.after_frame = [&](const InertialNavigator& nav, int k, double t) {
        const bool estimated = nav.status().R_camera_imu_estimated;
        if (estimated && switched_at < 0) switched_at = k;
        if (!estimated && nav.predict(t, t + 0.001).rotation_from_imu) {
          ++seeded_rotation_before_switch;
        }
      };
      const InertialStatus st = test::run_true_poses(motion, config, o, bias).status();
      ASSERT_TRUE(st.R_camera_imu_estimated) << synth::to_string(kind) << " seed " << seed;
      EXPECT_EQ(seeded_rotation_before_switch, 0);
      EXPECT_GE(switched_at, config.hand_eye_min_pairs);
      const double error = test::angle_between(st.R_camera_imu.toRotationMatrix(), truth);
      // The reported sigma is honest (3 sigma) and the estimate within the switching threshold.
      EXPECT_LT(error, 3.0 * st.R_camera_imu_sigma_deg * kDeg) << synth::to_string(kind);
      EXPECT_LT(error, 3.0 * config.hand_eye_max_sigma_deg * kDeg) << synth::to_string(kind);
      EXPECT_LT(st.R_camera_imu_sigma_deg, config.hand_eye_max_sigma_deg);
      // The bias is estimated too, within its own reported uncertainty (it is correlated with
      // the mounting while the motion is mostly a steady turn).
      const double bias_error = (st.gyro_bias - bias.gyro).norm();
      EXPECT_LT(bias_error, 3.0 * st.gyro_bias_sigma.norm()) << synth::to_string(kind);
      EXPECT_LT(bias_error, 0.5 * bias.gyro.norm()) << synth::to_string(kind);
    }
  }
}

// A given mounting stays in use, and the hand-eye estimate checks it: the phone's axes given as
// the camera's (identity, 180 deg off) are reported as disagreeing, the true mounting is not.
TEST(InertialHandEye, ChecksAGivenMounting) {
  const Eigen::Matrix3d truth = synth::default_T_camera_imu().linear();
  for (const synth::SceneKind kind : {synth::SceneKind::kRoom, synth::SceneKind::kFast}) {
    const std::uint64_t seed = 23;
    const synth::CameraMotion motion(kind, seed);
    const synth::ImuBias bias = synth::draw_imu_bias(seed);
    test::RunOptions o;
    o.seed = seed;
    InertialConfig config;
    config.T_camera_imu_known = true;
    config.T_camera_imu = Eigen::Isometry3d::Identity();  // wrong
    InertialStatus st = test::run_true_poses(motion, config, o, bias).status();
    EXPECT_TRUE(st.R_camera_imu_disagrees) << synth::to_string(kind);
    EXPECT_NEAR(st.R_camera_imu_disagreement_deg, rotation_deg(truth), 3.0);
    EXPECT_LT(test::angle_between(st.R_camera_imu_check.toRotationMatrix(), truth), 3.0 * kDeg);
    EXPECT_TRUE(st.R_camera_imu.toRotationMatrix().isIdentity());  // the given one stays
    EXPECT_FALSE(st.R_camera_imu_estimated);

    config.T_camera_imu.linear() = truth;
    st = test::run_true_poses(motion, config, o, bias).status();
    EXPECT_FALSE(st.R_camera_imu_disagrees) << synth::to_string(kind);
    EXPECT_GT(st.R_camera_imu_disagreement_deg, 0.0);  // checked
    EXPECT_LT(st.R_camera_imu_disagreement_deg, config.mounting_check_deg);
  }
}

/// Pairs (camera rotation with 0.01 deg of tracking noise, IMU integration) for the given IMU
/// rotation vectors.
void add_pairs(inertial::HandEyeCalibrator& calibrator, const Eigen::Matrix3d& R_ci,
               const std::vector<Eigen::Vector3d>& imu_rotations, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 0.01 * kDeg);
  for (const Eigen::Vector3d& a : imu_rotations) {
    inertial::ImuIntegration integ;
    integ.R_a_b = imufusion::exp_so3(a);
    integ.J_bias = -Eigen::Matrix3d::Identity() / 30.0;
    const Eigen::Vector3d noise(n(rng), n(rng), n(rng));
    calibrator.add(R_ci * imufusion::exp_so3(a + noise) * R_ci.transpose(), integ);
  }
}

TEST(InertialHandEye, NeedsRotationAboutTwoAxes) {
  const Eigen::Matrix3d R_ci = synth::default_T_camera_imu().linear();
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0 * kDeg);  // ~1 deg per frame
  std::vector<Eigen::Vector3d> one_axis, two_axes;
  for (int k = 0; k < 200; ++k) {
    one_axis.push_back(Eigen::Vector3d(0, n(rng), 0));  // a pure pan about IMU y
    two_axes.push_back(Eigen::Vector3d(n(rng), n(rng), 0));
  }
  inertial::HandEyeCalibrator pan(1000), tilt_and_pan(1000);
  add_pairs(pan, R_ci, one_axis, rng);
  add_pairs(tilt_and_pan, R_ci, two_axes, rng);
  const auto poor = pan.solve(Eigen::Vector3d::Zero());
  const auto good = tilt_and_pan.solve(Eigen::Vector3d::Zero());
  EXPECT_GT(poor.sigma, 5.0 * kDeg);  // the rotation about the pan axis is undetermined
  EXPECT_LT(good.sigma, 0.1 * kDeg);
  EXPECT_LT(test::angle_between(good.R_camera_imu, R_ci), 0.1 * kDeg);
  EXPECT_EQ(good.pairs, 200);
}

TEST(InertialHandEye, SolvesTheBiasJointly) {
  // Gyro rotations carry a bias of 0.02 rad/s (0.04 deg per pair against ~2 deg of rotation).
  const Eigen::Matrix3d R_ci = synth::default_T_camera_imu().linear();
  const Eigen::Vector3d b(0.02, -0.015, 0.01);
  std::mt19937 rng(6);
  std::normal_distribution<double> n(0.0, 2.0 * kDeg);
  inertial::HandEyeCalibrator calibrator(1000);
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d a(n(rng), n(rng), n(rng));
    inertial::ImuIntegration integ;
    // Measured with zero bias removed: R_meas = R_true Exp(-J b) with J = -dt I.
    integ.R_a_b = imufusion::exp_so3(a) * imufusion::exp_so3(b / 30.0);
    integ.J_bias = -Eigen::Matrix3d::Identity() / 30.0;
    calibrator.add(R_ci * imufusion::exp_so3(a) * R_ci.transpose(), integ);
  }
  const auto sol = calibrator.solve(Eigen::Vector3d::Zero());
  EXPECT_LT(test::angle_between(sol.R_camera_imu, R_ci), 0.01 * kDeg);
  EXPECT_LT((sol.gyro_bias - b).norm(), 1e-4);
}

}  // namespace
}  // namespace imufusion
