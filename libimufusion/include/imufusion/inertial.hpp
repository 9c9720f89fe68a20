#pragma once
// Inertial navigation between depth frames (Niessner, Dai, Fisher, EG 2014): ICP for frame t
// starts from T_world_{t-1} * dIMU, where dIMU is the camera's motion between the frames
// predicted from the IMU; while ICP is unreliable the pose is dead-reckoned with dIMU.
//
// Frames and units: T_a_b maps b-coordinates into a. The IMU frame is the frame of ImuSample
// (gyro rad/s, accel m/s^2 specific force); T_camera_imu maps IMU coordinates into the camera
// frame. "World" is whatever frame the caller's tracked poses T_world_camera are in; gravity is
// estimated in it, so it need not be z-up. Times are seconds on the sample clock.
//
// Rate at an instant t (gyro and accelerometer alike):
//   - between two samples at most `max_sample_gap` apart: linear interpolation (frame stamps
//     fall between samples; the two straddling samples define the rate at the frame);
//   - otherwise, within `max_extrapolation` of a sample (before the first, after the last,
//     inside a longer gap): the nearest sample's rate is held;
//   - otherwise: no rate.
// An interval [ta, tb] is integrated piecewise between these breakpoints and every sample
// stamp, each piece with its midpoint rate (exact for piecewise-linear rates) through the exact
// SO(3) exponential. If any part of [ta, tb] has no rate, the prediction reports
// rotation_from_imu = false and an identity rotation (a partial rotation would be a wrong seed);
// covered_fraction tells how much was interpolated. So a frame that arrives before the samples
// covering it gets the rate held for up to max_extrapolation and no IMU rotation beyond that;
// samples that arrive later are still accepted and serve every later predict() call, including
// one for the same interval.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <string_view>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

class StateArchive;  // src/core/state_archive.hpp

/// How the translation between frames is predicted.
/// kNone: zero translation (the paper: the IMU seeds rotation only).
/// kConstantVelocity: the velocity of recent tracked frames, held.
/// kAccelerometer: tracked velocity propagated with the accelerometer (gravity removed; gravity
///   estimated in the world frame). Falls back to constant velocity while gravity is not yet
///   estimated or the gyro does not cover the interval.
enum class TranslationModel { kNone, kConstantVelocity, kAccelerometer };

/// "none", "constant-velocity", "accelerometer".
const char* to_string(TranslationModel model);
std::optional<TranslationModel> parse_translation_model(std::string_view name);

struct InertialConfig {
  /// Maps IMU coordinates into camera coordinates (imu_to_camera.txt).
  Eigen::Isometry3d T_camera_imu = Eigen::Isometry3d::Identity();
  /// false: the rotation of T_camera_imu is estimated online (hand-eye) and its translation (the
  /// lever arm) taken as zero; until the estimate is confident, predictions carry no IMU
  /// rotation, since a wrong mounting (a phone frame is 180 deg off a camera frame) makes the
  /// seed worse than none.
  bool T_camera_imu_known = true;
  /// Estimate the gyro bias online from reliable ICP rotations.
  bool estimate_gyro_bias = true;
  /// rad/s, IMU frame: the starting bias estimate.
  Eigen::Vector3d initial_gyro_bias = Eigen::Vector3d::Zero();
  /// Chosen from bench/inertial_models.cpp (bench/README.md, "Inertial prediction"): on the
  /// synthetic scenes the accelerometer halves constant velocity's frame-to-frame error (median
  /// 0.5 vs 1.2-1.5 mm, p95 0.9 vs 2.1-4.4 mm) and its drift over 2 s of dead reckoning.
  TranslationModel translation = TranslationModel::kAccelerometer;

  /// s: how far from a sample its rate may be held (one 30 Hz frame: a hand-held rotation rate
  /// changes by ~5 rad/s^2 * 33 ms, so holding it costs at most ~0.15 deg per frame).
  double max_extrapolation = 1.0 / 30.0;
  /// s: consecutive samples further apart than this are a dropout, not interpolated across
  /// (4 periods of a 100 Hz IMU; a 200 Hz phone IMU jitters by < 1 period).
  double max_sample_gap = 0.04;
  /// s: samples older than the newest minus this are forgotten (frames come < 1 s apart).
  double sample_history = 5.0;

  /// rad/s, 1 sigma: prior uncertainty of initial_gyro_bias per axis (phone MEMS gyros: up to
  /// ~0.02 rad/s, draw_imu_bias() draws 0.01-0.02).
  double gyro_bias_prior_sigma = 0.03;
  /// rad/s/sqrt(s): bias random walk, lets the estimate follow slow thermal drift.
  double gyro_bias_random_walk = 1e-4;
  /// rad/s/sqrt(Hz): gyro white noise density (synthetic and TUM sequences: 0.003).
  double gyro_noise_density = 0.003;
  /// rad, 1 sigma: error of one reliable ICP relative rotation (good pairs land within 1 deg,
  /// bench/README.md "ICP reliability thresholds"; typically ~0.1 deg).
  double icp_rotation_sigma = 0.1 * std::numbers::pi / 180.0;

  /// Hand-eye: the estimate replaces the given rotation once at least this many pairs were used
  /// and the rotation's standard deviation about its least constrained axis is below
  /// hand_eye_max_sigma_deg (it needs rotation about two axes at least). A mounting error e
  /// turns a frame rotation of angle theta by at most theta * e: at 90 deg/s (3 deg per frame)
  /// 1 deg costs 0.05 deg, far inside ICP's basin; the synthetic room reaches it in ~10-20 s.
  int hand_eye_min_pairs = 60;
  double hand_eye_max_sigma_deg = 1.0;
  /// Pairs kept for the hand-eye solve (the oldest are dropped): ~30 s at 30 Hz.
  int hand_eye_max_pairs = 900;
  /// deg: a given mounting (T_camera_imu_known) is checked against the hand-eye estimate (once
  /// its sigma is below this), and reported as disagreeing (InertialStatus::
  /// R_camera_imu_disagrees) when the estimate is farther than this and 3 sigma from it. Below
  /// 5 deg a mounting error costs at most 0.26 deg per 3 deg frame rotation, inside ICP's reach;
  /// a wrongly given axis convention is 90-180 deg (bench/README.md, "The given mounting").
  double mounting_check_deg = 5.0;

  /// m, 1 sigma: error of a reliable tracked camera position, used to weigh tracked velocity.
  double tracking_position_sigma = 0.002;
  /// m/s/sqrt(s): velocity random walk of the constant-velocity model (hand-held accelerations
  /// of ~0.5 m/s^2 that persist ~0.5 s).
  double constant_velocity_process_noise = 0.35;
  /// m/s/sqrt(s): velocity random walk with the accelerometer (its white noise, bias and
  /// gravity-direction error; draw_imu_bias() biases are 0.02-0.06 m/s^2).
  double accelerometer_process_noise = 0.08;
  /// m/s: above this velocity uncertainty no translation is predicted.
  double max_velocity_sigma = 0.3;
  /// Dead reckoning stays where a hand-held device can be: s without a tracked frame after
  /// which the accelerometer no longer drives the velocity (gravity and bias errors grow its
  /// drift with t^3) and the velocity decays to zero with time constant velocity_decay_time (s);
  /// m/s: the speed is never above max_speed (bench/README.md, "Bounded dead reckoning").
  double accelerometer_dead_reckoning_time = 6.0;
  double velocity_decay_time = 0.5;
  double max_speed = 2.0;
  /// s: reliable tracked time before gravity is trusted; and the forgetting time constant of
  /// the gravity and accelerometer-bias estimate.
  double gravity_min_time = 1.0;
  double gravity_time_constant = 60.0;
  /// s: the longest chain of tracked frames fitted at once for gravity, accelerometer bias and
  /// velocity (longer chains see more of the acceleration's t^2 effect; tracking drift, which is
  /// not white, grows with length).
  double gravity_chain_time = 3.0;
  /// m/s^2, 1 sigma per axis: prior of the accelerometer bias (phone MEMS accelerometers: up to
  /// ~0.1; draw_imu_bias() draws 0.02-0.06). Bias and gravity separate only as the device turns.
  double accelerometer_bias_prior_sigma = 0.1;

  /// Fails naming the first field out of range.
  Status validate() const;
};

/// The camera's motion from frame a to frame b.
struct MotionPrediction {
  /// Maps camera-b coordinates into camera-a.
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  bool rotation_from_imu = false;  // false: no usable gyro data (or mounting) -> identity
  bool translation_predicted = false;
  double covered_fraction = 0;  // of [ta, tb] interpolated between samples
  int samples_used = 0;
  /// 1 sigma per axis of the predicted rotation (rad: gyro white noise and the bias estimate's
  /// uncertainty over the interval) and translation (m: the velocity estimate's uncertainty and
  /// the velocity random walk over the interval); 0 when not predicted.
  double rotation_sigma = 0;
  double translation_sigma = 0;
  /// The translation is an inertial estimate: the accelerometer propagated a velocity tracked
  /// well enough (known at least twice as well as one tracked frame pair measures it), not one
  /// pair's tracking error carried forward or a constant-velocity guess.
  bool translation_inertial = false;
};

/// Per-frame report of the estimators.
struct InertialStatus {
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();        // rad/s, IMU frame, current estimate
  Eigen::Vector3d gyro_bias_sigma = Eigen::Vector3d::Zero();  // rad/s, 1 sigma per axis
  int bias_updates = 0;                                       // reliable pairs used
  int bias_rejected = 0;  // reliable pairs refused by the consistency gate
  /// The mounting rotation in use (maps IMU into camera coordinates).
  Eigen::Quaterniond R_camera_imu = Eigen::Quaterniond::Identity();
  bool R_camera_imu_estimated = false;  // the hand-eye estimate is in use
  /// deg, 1 sigma about the least constrained axis of the latest hand-eye solve (infinity
  /// before two axes were excited); 0 when the rotation was given.
  double R_camera_imu_sigma_deg = 0;
  int hand_eye_pairs = 0;
  /// deg: angle between a given mounting rotation and the hand-eye estimate checking it; 0
  /// while the rotation is estimated or no estimate is good to mounting_check_deg yet.
  double R_camera_imu_disagreement_deg = 0;
  /// The given mounting disagrees with the motion (InertialConfig::mounting_check_deg): its axes
  /// are probably wrong. The given rotation stays in use; the estimate is in R_camera_imu_check.
  bool R_camera_imu_disagrees = false;
  Eigen::Quaterniond R_camera_imu_check = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gravity_world = Eigen::Vector3d::Zero();  // m/s^2, world frame
  Eigen::Vector3d gravity_sigma = Eigen::Vector3d::Zero();  // m/s^2, 1 sigma per axis
  bool gravity_ready = false;
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();        // m/s^2, IMU frame
  Eigen::Vector3d accel_bias_sigma = Eigen::Vector3d::Zero();  // m/s^2, 1 sigma per axis
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();    // m/s, IMU point, world frame
  double velocity_sigma = 0;                                   // m/s, 1 sigma per axis
};

class InertialNavigator {
 public:
  static Result<InertialNavigator> create(const InertialConfig& config);

  InertialNavigator(InertialNavigator&&) noexcept;
  InertialNavigator& operator=(InertialNavigator&&) noexcept;
  ~InertialNavigator();

  /// Appends samples, oldest first, in any batch size. Fails with nothing applied on a NaN/inf
  /// value (naming it and its timestamp) and on a sample older than the one before it (the last
  /// accepted one, or its predecessor in the batch; naming both timestamps). A sample with the
  /// same timestamp as the previous one is a second reading of that instant: the readings are
  /// averaged into one sample (drivers repeat stamps; dropping either would lose a reading).
  Status add_samples(std::span<const ImuSample> samples);
  /// Newest sample time, s; -infinity when none.
  double latest_sample_time() const;
  /// Samples exist up to t (t <= latest_sample_time()).
  bool covers(double t) const;

  /// The camera's motion from ta to tb (ta <= tb): gyro integrated (see the top of this file),
  /// bias removed, rotated into the camera frame; translation per config.translation from the
  /// navigator's memory of the last observed frame (predicted only when ta is that frame's
  /// time, within 1 ms).
  MotionPrediction predict(double ta, double tb) const;

  /// The outcome of frame b: its pose, the pose of frame a it was tracked from, and whether ICP
  /// was reliable. Reliable pairs update the bias and hand-eye estimators, gravity and the
  /// velocity; unreliable ones propagate the velocity by the model. Ignored when tb <= ta.
  void observe(double ta, double tb, const Eigen::Isometry3d& T_world_a,
               const Eigen::Isometry3d& T_world_b, bool reliable);

  InertialStatus status() const;
  /// Forgets the velocity (after a pose jump that was no motion: a wrong fit corrected); keeps
  /// the last frame, gravity and the calibration. Translation is predicted again once tracked
  /// pairs have measured the velocity.
  void forget_velocity();
  /// Adds `dv` (world, m/s) to the velocity (a correction measured elsewhere); nothing when
  /// there is no velocity.
  void correct_velocity(const Eigen::Vector3d& dv);
  /// Forgets the tracking memory (last frame, velocity, gravity: all tied to the tracked world
  /// frame); keeps the samples and the calibration (bias, mounting rotation).
  void reset();
  /// Writes or reads the changing state (not the configuration) for a saved scan.
  void describe(StateArchive& archive);

 private:
  struct State;
  explicit InertialNavigator(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace imufusion
