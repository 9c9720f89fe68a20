// Translation models on analytic motions with exact IMU samples: constant velocity is exact on a
// constant-velocity path, the accelerometer model on a constant-acceleration one (with a lever
// arm and gravity it has to estimate), none predicts nothing; dead reckoning, resets, names.

#include <gtest/gtest.h>

#include <algorithm>

#include "core/inertial_internal.hpp"
#include "inertial_test_fixtures.hpp"

namespace imufusion {
namespace {

using test::kDeg;

/// Camera with a constant body rate and constant world acceleration; world z up.
struct AnalyticMotion {
  Eigen::Matrix3d R0 =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::Vector3d omega_camera = Eigen::Vector3d(0.2, -0.4, 0.3);  // rad/s, camera frame
  Eigen::Vector3d p0 = Eigen::Vector3d(1.0, 2.0, 1.5);
  Eigen::Vector3d v0 = Eigen::Vector3d(0.3, -0.2, 0.1);
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();       // m/s^2, world
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // m/s^2, IMU frame, added to readings
  Eigen::Isometry3d T_camera_imu = synth::default_T_camera_imu();

  Eigen::Isometry3d pose(double t) const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R0 * imufusion::exp_so3(omega_camera * t);
    T.translation() = p0 + v0 * t + 0.5 * accel * t * t;
    return T;
  }
  std::vector<ImuSample> samples(double t0, double t1) const {
    const Eigen::Matrix3d R_ci = T_camera_imu.linear();
    const Eigen::Vector3d lever = T_camera_imu.translation();
    std::vector<ImuSample> out;
    for (int k = 0; t0 + k * 0.005 <= t1; ++k) {
      ImuSample s;
      s.timestamp = t0 + k * 0.005;
      const Eigen::Matrix3d R_wc = pose(s.timestamp).linear();
      // IMU point p_c + R_wc l: its acceleration adds R_wc w x (w x l) for a constant body rate.
      const Eigen::Vector3d a_imu = accel + R_wc * omega_camera.cross(omega_camera.cross(lever));
      s.gyro = R_ci.transpose() * omega_camera;
      s.accel = (R_wc * R_ci).transpose() * (a_imu - synth::gravity_world()) + accel_bias;
      out.push_back(s);
    }
    return out;
  }
};

struct TranslationErrors {
  double median = 0, max = 0;  // m, over the evaluated frames
  InertialStatus status;
};

/// Tracks `seconds` of frames with the true poses; the error of each prediction's translation
/// is measured over the frames after `evaluate_from` seconds.
TranslationErrors run(const AnalyticMotion& m, TranslationModel model, double seconds,
                      double evaluate_from) {
  InertialConfig config;
  config.T_camera_imu = m.T_camera_imu;
  config.translation = model;
  config.estimate_gyro_bias = false;
  config.max_speed = 100;  // the analytic motion speeds up for seconds, past any hand-held device
  InertialNavigator nav = InertialNavigator::create(config).value();
  EXPECT_TRUE(nav.add_samples(m.samples(0.0, seconds + 0.1)).ok());
  std::vector<double> errors;
  const double dt = 1.0 / 30.0;
  for (int k = 1; k * dt <= seconds; ++k) {
    const double ta = (k - 1) * dt, tb = k * dt;
    const MotionPrediction p = nav.predict(ta, tb);
    const Eigen::Isometry3d truth = m.pose(ta).inverse() * m.pose(tb);
    if (ta >= evaluate_from) {
      EXPECT_TRUE(p.rotation_from_imu);
      EXPECT_EQ(p.translation_predicted, model != TranslationModel::kNone);
      EXPECT_LT(test::angle_between(p.T_a_b.linear(), truth.linear()), 1e-6);
      errors.push_back((p.T_a_b.translation() - truth.translation()).norm());
    }
    nav.observe(ta, tb, m.pose(ta), m.pose(tb), true);
  }
  std::sort(errors.begin(), errors.end());
  TranslationErrors out;
  out.median = errors[errors.size() / 2];
  out.max = errors.back();
  out.status = nav.status();
  return out;
}

TEST(InertialTranslation, ConstantVelocityIsExactOnAConstantVelocityPath) {
  AnalyticMotion m;
  m.omega_camera.setZero();  // a rotating lever arm would make the IMU point accelerate
  const TranslationErrors cv = run(m, TranslationModel::kConstantVelocity, 2.0, 0.1);
  EXPECT_LT(cv.max, 1e-9);
  EXPECT_LT((cv.status.velocity_world - m.v0).norm(), 1e-9);
  const TranslationErrors none = run(m, TranslationModel::kNone, 2.0, 0.1);
  // No translation predicted: the error is the whole step, |v0| / 30.
  EXPECT_NEAR(none.median, m.v0.norm() / 30.0, 1e-9);
}

TEST(InertialTranslation, AccelerometerModelFollowsAccelerationWithGravityEstimated) {
  AnalyticMotion m;
  m.accel = Eigen::Vector3d(1.5, -0.5, 0.8);  // m/s^2: a brisk hand-held push
  const TranslationErrors acc = run(m, TranslationModel::kAccelerometer, 4.0, 3.0);
  const TranslationErrors cv = run(m, TranslationModel::kConstantVelocity, 4.0, 3.0);
  // Constant velocity misses ~ a dt^2 (1.9 mm); the accelerometer integrates it.
  EXPECT_GT(cv.median, 0.5 * m.accel.norm() / 900.0);
  EXPECT_LT(acc.max, 0.01e-3);
  ASSERT_TRUE(acc.status.gravity_ready);
  // Gravity from consecutive pairs is exact on exact data.
  EXPECT_LT((acc.status.gravity_world - synth::gravity_world()).norm(), 1e-3);
}

/// Tracks `tracked` s with the true poses, then dead-reckons `dark` s; the position error at
/// the end (m) and the estimator state at the end of tracking.
struct DeadReckoning {
  double drift = 0;
  InertialStatus tracked_status;
};
DeadReckoning dead_reckon(const AnalyticMotion& m, const InertialConfig& base, double tracked,
                          double dark) {
  InertialConfig config = base;
  config.T_camera_imu = m.T_camera_imu;
  config.estimate_gyro_bias = false;
  config.max_speed = 100;
  InertialNavigator nav = InertialNavigator::create(config).value();
  EXPECT_TRUE(nav.add_samples(m.samples(0.0, tracked + dark + 0.1)).ok());
  const double dt = 1.0 / 30.0;
  Eigen::Isometry3d pose = m.pose(0.0);
  DeadReckoning out;
  const int frames = static_cast<int>(std::lround((tracked + dark) / dt));
  for (int k = 1; k <= frames; ++k) {
    const double ta = (k - 1) * dt, tb = k * dt;
    const bool reliable = tb <= tracked + 1e-9;
    const Eigen::Isometry3d next = reliable ? m.pose(tb) : pose * nav.predict(ta, tb).T_a_b;
    nav.observe(ta, tb, pose, next, reliable);
    pose = next;
    if (reliable) out.tracked_status = nav.status();
  }
  out.drift = (pose.translation() - m.pose(frames * dt).translation()).norm();
  return out;
}

TEST(InertialTranslation, AccelerometerBiasIsEstimatedWhileTheDeviceTurns) {
  AnalyticMotion m;  // turning at ~0.5 rad/s: the bias turns against gravity and separates
  m.accel = Eigen::Vector3d(0.4, -0.3, 0.2);
  m.accel_bias = Eigen::Vector3d(0.05, -0.04, 0.03);  // phone-grade, m/s^2
  InertialConfig estimated;
  const DeadReckoning with = dead_reckon(m, estimated, 4.0, 2.0);
  ASSERT_TRUE(with.tracked_status.gravity_ready);
  // A turn about one fixed axis leaves the bias along that axis where gravity is (it never
  // turns against gravity): only the bias across the axis is observable, and is estimated.
  const Eigen::Vector3d axis = (m.T_camera_imu.linear().transpose() * m.omega_camera).normalized();
  const Eigen::Vector3d bias_error = with.tracked_status.accel_bias - m.accel_bias;
  EXPECT_LT((bias_error - bias_error.dot(axis) * axis).norm(), 2e-3) << bias_error.transpose();
  // A bias held at zero (a prior of 1e-6 m/s^2) leaves gravity to absorb it: the dead-reckoned
  // position then drifts by centimetres over 2 s.
  InertialConfig held = estimated;
  held.accelerometer_bias_prior_sigma = 1e-6;
  const DeadReckoning without = dead_reckon(m, held, 4.0, 2.0);
  EXPECT_GT(without.drift, 0.02);
  EXPECT_LT(with.drift, 0.2 * without.drift);
  EXPECT_LT(with.drift, 0.005);
}

// A constant-velocity navigator given `m`'s samples over [0, seconds].
InertialNavigator constant_velocity_navigator(const AnalyticMotion& m, const InertialConfig& config,
                                              double seconds) {
  InertialNavigator nav = InertialNavigator::create(config).value();
  EXPECT_TRUE(nav.add_samples(m.samples(0.0, seconds)).ok());
  return nav;
}

InertialConfig constant_velocity_config(const AnalyticMotion& m) {
  InertialConfig config;
  config.T_camera_imu = m.T_camera_imu;
  config.translation = TranslationModel::kConstantVelocity;
  return config;
}

TEST(InertialTranslation, DeadReckoningHoldsVelocityUntilItsUncertaintyIsTooLarge) {
  AnalyticMotion m;
  m.omega_camera.setZero();
  const InertialConfig config = constant_velocity_config(m);
  InertialNavigator nav = constant_velocity_navigator(m, config, 4.0);
  const double dt = 1.0 / 30.0;
  Eigen::Isometry3d pose = m.pose(0.0);
  int last_predicted = -1;
  double previous_sigma = 0;
  for (int k = 1; k <= 90; ++k) {
    const double ta = (k - 1) * dt, tb = k * dt;
    const MotionPrediction p = nav.predict(ta, tb);
    if (p.translation_predicted) {
      last_predicted = k;
      // The velocity's uncertainty over the step and the random walk's within it.
      const double sv = nav.status().velocity_sigma, q = config.constant_velocity_process_noise;
      EXPECT_NEAR(p.translation_sigma, std::sqrt(sv * sv * dt * dt + q * q * dt * dt * dt / 3),
                  1e-12);
      if (k > 32) {
        EXPECT_GT(p.translation_sigma, previous_sigma);  // grows while dead reckoning
      }
      previous_sigma = p.translation_sigma;
    } else {
      EXPECT_EQ(p.translation_sigma, 0.0);
    }
    const bool reliable = k <= 30;  // then 2 s of dead reckoning from the prediction
    const Eigen::Isometry3d next = reliable ? m.pose(tb) : pose * p.T_a_b;
    nav.observe(ta, tb, pose, next, reliable);
    pose = next;
    if (k == 40) {
      // A third of a second into dead reckoning the held velocity is still exact.
      EXPECT_LT((pose.translation() - m.pose(tb).translation()).norm(), 1e-9);
    }
  }
  // sigma grows as 0.35 m/s/sqrt(s): it passes max_velocity_sigma (0.3 m/s) after ~0.73 s.
  EXPECT_GT(last_predicted, 30 + 15);
  EXPECT_LT(last_predicted, 30 + 30);
  EXPECT_GT(nav.status().velocity_sigma, config.max_velocity_sigma);
}

TEST(InertialTranslation, ResetAndForeignStartTimesPredictNoTranslation) {
  AnalyticMotion m;
  InertialConfig config;
  config.T_camera_imu = m.T_camera_imu;
  config.translation = TranslationModel::kConstantVelocity;
  InertialNavigator nav = InertialNavigator::create(config).value();
  ASSERT_TRUE(nav.add_samples(m.samples(0.0, 2.0)).ok());
  EXPECT_FALSE(nav.predict(0.0, 0.1).translation_predicted);  // nothing observed yet
  nav.observe(0.0, 0.1, m.pose(0.0), m.pose(0.1), true);
  nav.observe(0.1, 0.2, m.pose(0.1), m.pose(0.2), true);
  EXPECT_TRUE(nav.predict(0.2, 0.3).translation_predicted);
  EXPECT_FALSE(nav.predict(0.25, 0.3).translation_predicted);  // not from the last frame
  const Eigen::Vector3d bias = nav.status().gyro_bias;
  nav.reset();
  EXPECT_FALSE(nav.predict(0.2, 0.3).translation_predicted);
  EXPECT_TRUE(nav.predict(0.2, 0.3).rotation_from_imu);
  EXPECT_EQ(nav.status().gyro_bias, bias);
}

// A velocity correction measured elsewhere (after a loss, from the drift it showed) moves the
// next prediction by the correction over the interval; with no velocity there is nothing to
// correct.
TEST(InertialTranslation, ACorrectedVelocityMovesTheNextPrediction) {
  AnalyticMotion m;
  m.omega_camera.setZero();
  InertialNavigator nav = constant_velocity_navigator(m, constant_velocity_config(m), 2.0);
  const double dt = 1.0 / 30.0;
  for (int k = 1; k <= 5; ++k)
    nav.observe((k - 1) * dt, k * dt, m.pose((k - 1) * dt), m.pose(k * dt), true);
  const MotionPrediction before = nav.predict(5 * dt, 6 * dt);
  ASSERT_TRUE(before.translation_predicted);
  const Eigen::Vector3d dv(0.2, -0.1, 0.05);  // world
  nav.correct_velocity(dv);
  const MotionPrediction after = nav.predict(5 * dt, 6 * dt);
  ASSERT_TRUE(after.translation_predicted);
  EXPECT_LT((nav.status().velocity_world - (m.v0 + dv)).norm(), 1e-9);
  EXPECT_LT(
      (after.T_a_b.translation() - before.T_a_b.translation() - m.R0.transpose() * dv * dt).norm(),
      1e-9);
  nav.forget_velocity();
  nav.correct_velocity(dv);
  EXPECT_FALSE(nav.predict(5 * dt, 6 * dt).translation_predicted);
}

// Tracks a device at rest for 3 s, gives the navigator a velocity error `dv` (world, m/s), then
// dead-reckons for `dark` s; the position error at the end (m).
double drift_from_velocity_error(const InertialConfig& base, const Eigen::Vector3d& dv,
                                 double dark) {
  AnalyticMotion m;
  m.omega_camera.setZero();
  m.v0.setZero();
  InertialConfig config = base;
  config.T_camera_imu = m.T_camera_imu;
  config.estimate_gyro_bias = false;
  config.max_velocity_sigma = 10;  // keep predicting: the bounds alone must hold the position
  InertialNavigator nav = InertialNavigator::create(config).value();
  EXPECT_TRUE(nav.add_samples(m.samples(0.0, 3.0 + dark + 0.1)).ok());
  const double dt = 1.0 / 30.0;
  Eigen::Isometry3d pose = m.pose(0.0);
  const int tracked = 90, frames = tracked + static_cast<int>(std::lround(dark / dt));
  for (int k = 1; k <= frames; ++k) {
    const double ta = (k - 1) * dt, tb = k * dt;
    if (k == tracked + 1) nav.correct_velocity(dv);
    const bool reliable = k <= tracked;
    const Eigen::Isometry3d next = reliable ? m.pose(tb) : pose * nav.predict(ta, tb).T_a_b;
    nav.observe(ta, tb, pose, next, reliable);
    pose = next;
  }
  return (pose.translation() - m.pose(frames * dt).translation()).norm();
}

TEST(InertialTranslation, LongDeadReckoningStaysWhereAHandHeldDeviceCanBe) {
  // A velocity error carried into a loss: held, it moves the position linearly for ever; bounded,
  // the accelerometer carries it for accelerometer_dead_reckoning_time, then it decays.
  InertialConfig bounded;
  InertialConfig unbounded = bounded;
  unbounded.accelerometer_dead_reckoning_time = 1e9;
  unbounded.max_speed = 1e9;
  const Eigen::Vector3d dv(0.4, -0.2, 0.2);
  const double dark = 20.0;
  EXPECT_NEAR(drift_from_velocity_error(unbounded, dv, dark), dv.norm() * dark, 0.01);
  const double reach =
      dv.norm() * (bounded.accelerometer_dead_reckoning_time + bounded.velocity_decay_time);
  EXPECT_NEAR(drift_from_velocity_error(bounded, dv, dark), reach, 0.05 * reach);
  // A speed no hand-held device reaches is capped.
  const Eigen::Vector3d fast = 5.0 * dv.normalized();
  const double capped =
      bounded.max_speed * (bounded.accelerometer_dead_reckoning_time + bounded.velocity_decay_time);
  EXPECT_NEAR(drift_from_velocity_error(bounded, fast, dark), capped, 0.05 * capped);
}

TEST(InertialTranslation, ModelNamesRoundTrip) {
  for (const TranslationModel m : {TranslationModel::kNone, TranslationModel::kConstantVelocity,
                                   TranslationModel::kAccelerometer}) {
    EXPECT_EQ(parse_translation_model(to_string(m)), m);
  }
  EXPECT_FALSE(parse_translation_model("cv").has_value());
  EXPECT_FALSE(parse_translation_model("").has_value());
}

}  // namespace
}  // namespace imufusion
