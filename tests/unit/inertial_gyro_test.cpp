// Gyro integration rules of InertialNavigator: interpolation at the interval ends, the hold
// limit, late samples, dropouts, bad and duplicate samples, the bias Jacobian.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/inertial_internal.hpp"
#include "inertial_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::kDeg;

InertialNavigator make_navigator(InertialConfig config = {}) {
  config.estimate_gyro_bias = false;
  Result<InertialNavigator> nav = InertialNavigator::create(config);
  EXPECT_TRUE(nav.ok());
  return std::move(nav).value();
}

/// Samples every `period` s on [t0, t1] with rate w(t) = slope * t about z (rad/s).
std::vector<ImuSample> ramp_samples(double t0, double t1, double period, double slope) {
  std::vector<ImuSample> s;
  const auto n = static_cast<int>(std::lround((t1 - t0) / period));
  for (int i = 0; i <= n; ++i) {
    const double t = t0 + i * period;
    ImuSample x;
    x.timestamp = t;
    x.gyro = Eigen::Vector3d(0, 0, slope * t);
    s.push_back(x);
  }
  return s;
}

double yaw_of(const MotionPrediction& p) {
  return Eigen::AngleAxisd(p.T_a_b.linear()).angle() *
         Eigen::AngleAxisd(p.T_a_b.linear()).axis().z();
}

TEST(InertialGyro, RatesAreInterpolatedAtTheIntervalEnds) {
  // A linearly growing rate is integrated exactly only if the rate at ta and tb is interpolated
  // between the straddling samples (holding a sample's rate would be off by slope * dt * gap).
  InertialNavigator nav = make_navigator();
  const double slope = 4.0;  // rad/s^2
  ASSERT_TRUE(nav.add_samples(ramp_samples(0.0, 1.0, 0.01, slope)).ok());
  const double ta = 0.4031, tb = 0.4367;  // neither on a sample
  const MotionPrediction p = nav.predict(ta, tb);
  ASSERT_TRUE(p.rotation_from_imu);
  EXPECT_NEAR(p.covered_fraction, 1.0, 1e-12);
  EXPECT_NEAR(yaw_of(p), 0.5 * slope * (tb * tb - ta * ta), 1e-12);
  EXPECT_EQ(p.samples_used, 5);  // 0.40 .. 0.44 straddle [ta, tb]
  EXPECT_FALSE(p.translation_predicted);
}

TEST(InertialGyro, NoiselessSyntheticGyroGivesTheTrueCameraRotation) {
  synth::ImuConfig imu;
  imu.noise = false;
  imu.bias = false;
  const synth::CameraMotion motion(synth::SceneKind::kFast, 3);
  InertialConfig config;
  config.T_camera_imu = imu.T_camera_imu;
  config.sample_history = 10.0;  // keep all 8 s
  InertialNavigator nav = make_navigator(config);
  ASSERT_TRUE(nav.add_samples(synth::generate_imu(motion, imu, {}, 0.0, 8.0, 3)).ok());
  double worst = 0, largest = 0;
  for (double ta = 0.5; ta < 7.5; ta += 1.0 / 30.0) {
    const double tb = ta + 1.0 / 30.0;
    const MotionPrediction p = nav.predict(ta, tb);
    ASSERT_TRUE(p.rotation_from_imu);
    const Eigen::Matrix3d truth =
        motion.pose_at(ta).linear().transpose() * motion.pose_at(tb).linear();
    worst = std::max(worst, test::angle_between(p.T_a_b.linear(), truth));
    largest = std::max(largest, test::rotation_angle(truth));
  }
  EXPECT_LT(worst, 0.01 * kDeg);
  EXPECT_GT(largest, 2.0 * kDeg);  // the fast bursts turn > 60 deg/s
}

TEST(InertialGyro, RateIsHeldUpToMaxExtrapolationThenNoImuRotation) {
  InertialConfig config;
  config.max_extrapolation = 0.02;
  std::vector<ImuSample> constant = ramp_samples(0.0, 1.0, 0.005, 0.0);
  for (ImuSample& s : constant) s.gyro = Eigen::Vector3d(0, 0, 0.5);
  InertialNavigator held = make_navigator(config);
  ASSERT_TRUE(held.add_samples(constant).ok());
  EXPECT_TRUE(held.covers(0.9999));
  EXPECT_FALSE(held.covers(1.001));

  // 10 ms past the last sample: held at 0.5 rad/s.
  const MotionPrediction p = held.predict(0.99, 1.01);
  ASSERT_TRUE(p.rotation_from_imu);
  EXPECT_NEAR(p.covered_fraction, 0.5, 1e-9);
  EXPECT_NEAR(yaw_of(p), 0.5 * 0.02, 1e-12);
  // Exactly at the limit still counts; beyond it the IMU gives no rotation.
  EXPECT_TRUE(held.predict(0.99, 1.02).rotation_from_imu);
  const MotionPrediction beyond = held.predict(0.99, 1.03);
  EXPECT_FALSE(beyond.rotation_from_imu);
  EXPECT_TRUE(beyond.T_a_b.linear().isIdentity(0));
  EXPECT_NEAR(beyond.covered_fraction, 0.25, 1e-9);
  // Before the first sample the same rule holds.
  EXPECT_TRUE(held.predict(-0.02, 0.01).rotation_from_imu);
  EXPECT_FALSE(held.predict(-0.03, 0.01).rotation_from_imu);
}

TEST(InertialGyro, SamplesArrivingLateServeTheSameIntervalAfterwards) {
  InertialNavigator nav = make_navigator();
  const std::vector<ImuSample> all = ramp_samples(0.0, 2.0, 0.005, 1.0);
  const auto split = static_cast<std::size_t>(1.0 / 0.005);  // samples up to 0.995 s
  ASSERT_TRUE(nav.add_samples(std::span(all).first(split)).ok());
  const MotionPrediction early = nav.predict(1.2, 1.2 + 1.0 / 30.0);
  EXPECT_FALSE(early.rotation_from_imu);
  EXPECT_EQ(early.covered_fraction, 0.0);
  EXPECT_EQ(early.samples_used, 0);
  ASSERT_TRUE(nav.add_samples(std::span(all).subspan(split)).ok());
  const MotionPrediction late = nav.predict(1.2, 1.2 + 1.0 / 30.0);
  ASSERT_TRUE(late.rotation_from_imu);
  EXPECT_NEAR(late.covered_fraction, 1.0, 1e-12);
  const double tb = 1.2 + 1.0 / 30.0;
  EXPECT_NEAR(yaw_of(late), 0.5 * (tb * tb - 1.44), 1e-9);
}

TEST(InertialGyro, DropoutsAreNotInterpolatedAcross) {
  InertialConfig config;
  config.max_sample_gap = 0.04;
  config.max_extrapolation = 0.02;
  InertialNavigator nav = make_navigator(config);
  std::vector<ImuSample> s = ramp_samples(0.0, 1.0, 0.005, 0.0);
  const std::vector<ImuSample> after = ramp_samples(1.5, 2.0, 0.005, 0.0);
  s.insert(s.end(), after.begin(), after.end());
  for (ImuSample& x : s) x.gyro = Eigen::Vector3d(0.3, 0, 0);
  ASSERT_TRUE(nav.add_samples(s).ok());
  EXPECT_FALSE(nav.predict(1.2, 1.25).rotation_from_imu);
  EXPECT_FALSE(nav.predict(0.99, 1.51).rotation_from_imu);
  const MotionPrediction edge = nav.predict(0.99, 1.015);
  EXPECT_TRUE(edge.rotation_from_imu);
  EXPECT_NEAR(edge.covered_fraction, 0.4, 1e-9);
  EXPECT_TRUE(nav.predict(1.485, 1.6).rotation_from_imu);
}

TEST(InertialGyro, BadSamplesAreRefusedWithNothingApplied) {
  InertialNavigator nav = make_navigator();
  ASSERT_TRUE(nav.add_samples(ramp_samples(0.0, 0.1, 0.005, 0.0)).ok());
  const double before = nav.latest_sample_time();

  std::vector<ImuSample> batch = ramp_samples(0.105, 0.2, 0.005, 0.0);
  batch[3].gyro.y() = std::numeric_limits<double>::quiet_NaN();
  Status st = nav.add_samples(batch);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(st.error().message.find("gyro y"), std::string::npos) << st.error().message;
  EXPECT_NE(st.error().message.find("0.120000"), std::string::npos) << st.error().message;
  EXPECT_EQ(nav.latest_sample_time(), before);

  batch = ramp_samples(0.105, 0.2, 0.005, 0.0);
  batch[5].accel.z() = std::numeric_limits<double>::infinity();
  st = nav.add_samples(batch);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("accel z"), std::string::npos) << st.error().message;
  EXPECT_EQ(nav.latest_sample_time(), before);

  batch = ramp_samples(0.105, 0.2, 0.005, 0.0);
  batch[7].timestamp = 0.05;  // older than the last accepted (0.1) and its predecessor
  st = nav.add_samples(batch);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("0.050000"), std::string::npos) << st.error().message;
  EXPECT_NE(st.error().message.find("0.135000"), std::string::npos) << st.error().message;
  EXPECT_EQ(nav.latest_sample_time(), before);

  ImuSample old;
  old.timestamp = 0.095;
  st = nav.add_samples(std::span(&old, 1));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("0.100000"), std::string::npos) << st.error().message;
  EXPECT_TRUE(nav.add_samples(ramp_samples(0.105, 0.2, 0.005, 0.0)).ok());
  EXPECT_NEAR(nav.latest_sample_time(), 0.2, 1e-12);
}

TEST(InertialGyro, DuplicateTimestampsAreAveraged) {
  InertialNavigator nav = make_navigator();
  std::vector<ImuSample> s = ramp_samples(0.0, 1.0, 0.01, 0.0);
  for (ImuSample& x : s) x.gyro = Eigen::Vector3d(0, 0, 1.0);
  ASSERT_TRUE(nav.add_samples(s).ok());
  // Three more readings of t = 1.0 (one in a later batch): mean of 1, 2, 4, 5 = 3 rad/s.
  std::vector<ImuSample> dup(2, s.back());
  dup[0].gyro.z() = 2.0;
  dup[1].gyro.z() = 4.0;
  ASSERT_TRUE(nav.add_samples(dup).ok());
  dup.resize(1);
  dup[0].gyro.z() = 5.0;
  ASSERT_TRUE(nav.add_samples(dup).ok());
  ImuSample next = s.back();
  next.timestamp = 1.01;
  next.gyro.z() = 3.0;
  ASSERT_TRUE(nav.add_samples(std::span(&next, 1)).ok());
  EXPECT_NEAR(yaw_of(nav.predict(1.0, 1.01)), 0.03, 1e-12);
  EXPECT_NEAR(yaw_of(nav.predict(0.99, 1.0)), 0.02, 1e-12);
}

TEST(InertialGyro, BiasJacobianMatchesFiniteDifferences) {
  inertial::SampleBuffer buffer(0.03, 0.04, 10.0);
  synth::ImuConfig imu;
  const synth::CameraMotion motion(synth::SceneKind::kFast, 5);
  ASSERT_TRUE(buffer.append(synth::generate_imu(motion, imu, {}, 0.0, 3.0, 5)).ok());
  const Eigen::Vector3d b(0.01, -0.02, 0.015);
  const inertial::ImuIntegration base = buffer.integrate(1.1, 1.4, b, Eigen::Matrix3d::Identity());
  for (int a = 0; a < 3; ++a) {
    const double h = 1e-6;
    const Eigen::Vector3d db = h * Eigen::Vector3d::Unit(a);
    const inertial::ImuIntegration moved =
        buffer.integrate(1.1, 1.4, b + db, Eigen::Matrix3d::Identity());
    const Eigen::Vector3d numeric = imufusion::log_so3(base.R_a_b.transpose() * moved.R_a_b) / h;
    EXPECT_LT((numeric - base.J_bias.col(a)).norm(), 1e-5 * 0.3) << "axis " << a;
  }
  // About -dt I for a short interval, so the test's tolerance is meaningful.
  EXPECT_GT(base.J_bias.diagonal().cwiseAbs().minCoeff(), 0.2);
}

}  // namespace
}  // namespace imufusion
