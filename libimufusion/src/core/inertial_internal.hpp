#pragma once
// The parts of InertialNavigator, each testable alone: the sample buffer and its integration,
// the gyro bias estimator, the hand-eye rotation calibration and the velocity / gravity filter.
// Units: s, rad, rad/s, m, m/s, m/s^2. R_a_b maps b-coordinates into a.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <deque>
#include <limits>
#include <span>
#include <vector>

#include "core/so3.hpp"
#include "core/state_archive.hpp"
#include "imufusion/inertial.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion::inertial {

/// IMU motion over [ta, tb] integrated from the samples (see inertial.hpp for the rate rule).
struct ImuIntegration {
  Eigen::Matrix3d R_a_b = Eigen::Matrix3d::Identity();  // IMU at tb into IMU at ta
  /// d Log(R_a_b) / d bias, right perturbation: R_a_b(bias + d) ~ R_a_b Exp(J d). rad per rad/s;
  /// about -(tb - ta) I for small rotations.
  Eigen::Matrix3d J_bias = Eigen::Matrix3d::Zero();
  Eigen::Vector3d bias_used = Eigen::Vector3d::Zero();  // rad/s, removed from every rate
  /// World-frame integrals of the specific force rotated by R_world_imu(t) (starting from the
  /// R_world_imu_a given): delta_v = int f_w dt (m/s), delta_p = double integral (m). Gravity
  /// is not included.
  Eigen::Vector3d delta_v = Eigen::Vector3d::Zero();
  Eigen::Vector3d delta_p = Eigen::Vector3d::Zero();
  /// Their derivatives by an accelerometer bias b (IMU frame, m/s^2) removed from every reading:
  /// delta_v(b) = delta_v - Jv_accel b, delta_p(b) = delta_p - Jp_accel b (s and s^2, world frame).
  Eigen::Matrix3d Jv_accel = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d Jp_accel = Eigen::Matrix3d::Zero();
  bool complete = false;        // every part of [ta, tb] had a rate (interpolated or held)
  double covered_fraction = 0;  // interpolated part of [ta, tb]
  int samples_used = 0;
};

/// Time-ordered IMU samples with the interpolation / hold rule of inertial.hpp.
class SampleBuffer {
 public:
  SampleBuffer(double max_extrapolation, double max_sample_gap, double history);

  /// All-or-nothing append (see InertialNavigator::add_samples).
  Status append(std::span<const ImuSample> samples);
  double latest_time() const;
  bool empty() const { return samples_.empty(); }
  void describe(StateArchive& archive);  // the changing state, for a saved scan

  ImuIntegration integrate(double ta, double tb, const Eigen::Vector3d& bias,
                           const Eigen::Matrix3d& R_world_imu_a) const;

 private:
  enum class RateKind { kInterpolated, kHeld, kNone };
  struct Rate {
    RateKind kind = RateKind::kNone;
    Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
    Eigen::Vector3d accel = Eigen::Vector3d::Zero();
    std::size_t first = 0, last = 0;  // sample indices used
  };
  Rate rate_at(double t) const;
  std::vector<double> breakpoints(double ta, double tb) const;

  double max_extrapolation_, max_sample_gap_, history_;
  std::deque<ImuSample> samples_;
  int last_merged_ = 1;  // readings averaged into the newest sample
};

/// Recursive (Kalman) estimate of the gyro bias from pairs of a reliable ICP rotation and the
/// integrated gyro.
class GyroBiasEstimator {
 public:
  GyroBiasEstimator(const Eigen::Vector3d& initial_bias, double prior_sigma, double random_walk,
                    double noise_density, double icp_sigma);

  /// R_imu_icp: the tracked rotation of the pair in the IMU frame (IMU-b into IMU-a).
  /// mounting_sigma: rad, uncertainty of the camera-IMU rotation used to map the ICP rotation
  /// into the IMU frame; its error grows with the pair's rotation angle, so rotation-rich pairs
  /// weigh less while the mounting is uncertain. Returns false when the pair was gated out.
  bool update(double t, const ImuIntegration& integration, const Eigen::Matrix3d& R_imu_icp,
              double dt, double mounting_sigma);
  /// Replaces the state (e.g. by a hand-eye solve's joint estimate).
  void reset_to(const Eigen::Vector3d& bias, const Eigen::Matrix3d& covariance);

  const Eigen::Vector3d& bias() const { return bias_; }
  const Eigen::Matrix3d& covariance() const { return P_; }
  int updates() const { return updates_; }
  int rejected() const { return rejected_; }
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  Eigen::Vector3d bias_;
  Eigen::Matrix3d P_;
  double random_walk_, noise_density_, icp_sigma_;
  double last_time_ = 0;
  bool has_time_ = false;
  int updates_ = 0, rejected_ = 0;
};

/// Rotation hand-eye calibration R_c R_ci = R_ci R_i from pairs of rotations, jointly with the
/// gyro bias: rotation vectors a_c = R_ci a_i (Kabsch / SVD, rotation vectors carry their angle
/// as weight) alternated with the bias by linear least squares.
class HandEyeCalibrator {
 public:
  explicit HandEyeCalibrator(int max_pairs);

  /// R_camera_a_b: tracked camera rotation (camera-b into camera-a); the integration's rotation
  /// is in the IMU frame with its bias Jacobian.
  void add(const Eigen::Matrix3d& R_camera_a_b, const ImuIntegration& integration);

  struct Solution {
    Eigen::Matrix3d R_camera_imu = Eigen::Matrix3d::Identity();
    Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // rad/s, IMU frame
    Eigen::Matrix3d bias_covariance = Eigen::Matrix3d::Identity();
    double sigma = 0;  // rad, 1 sigma about the least constrained axis (inf: one axis only)
    int pairs = 0;
  };
  /// Solves from the stored pairs, starting the bias at `bias_guess`.
  Solution solve(const Eigen::Vector3d& bias_guess) const;
  int pairs() const { return static_cast<int>(pairs_.size()); }
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  struct Pair {
    Eigen::Vector3d a_camera, a_imu;  // rotation vectors, rad
    Eigen::Matrix3d J_bias;
    Eigen::Vector3d bias_used;
  };
  std::deque<Pair> pairs_;
  int max_pairs_;
};

/// Gravity (world frame) and the accelerometer bias (IMU frame) from chains of reliably tracked
/// frames. Within a chain the IMU point's positions follow
///   p_k = p_0 + v_0 tau_k + g tau_k^2 / 2 + D_k - J_k b,
/// D_k being the double integral of the measured specific force rotated into the world since the
/// chain's start and J_k its derivative by the bias. Linear least squares over the positions
/// (tracking_position_sigma each) gives (p_0, v_0, g, b): position-level, so the tracking noise
/// is not differentiated into velocities. A chain ends at an unreliable pair or after
/// max_chain_time; its information on (g, b) (p_0 and v_0 marginalized) carries over as a prior,
/// forgotten with forget_time. The bias has a zero-mean prior: with little rotation in a chain only
/// g - R b is seen, and the prior splits it.
class GravityBiasEstimator {
 public:
  GravityBiasEstimator(double position_sigma, double bias_prior_sigma, double max_chain_time,
                       double forget_time);

  /// One frame pair of dt s; p_a, p_b: IMU-point positions (world, m). An unreliable pair or an
  /// incomplete integration ends the chain.
  void step(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b, bool reliable,
            const ImuIntegration* integration);

  /// Tracked time (s, forgotten like the information) that went into the estimate.
  double support_time() const { return support_time_ + chain_tau_; }
  const Eigen::Vector3d& gravity() const { return gravity_; }
  const Eigen::Vector3d& accel_bias() const { return bias_; }
  /// 1 sigma per axis of gravity and bias (m/s^2); infinite before any chain carried information.
  const Eigen::Vector3d& gravity_sigma() const { return gravity_sigma_; }
  const Eigen::Vector3d& bias_sigma() const { return bias_sigma_; }

  /// Ends the current chain (a break in the frame sequence), keeping its information.
  void interrupt();
  void reset();
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  using Mat12 = Eigen::Matrix<double, 12, 12>;
  using Vec12 = Eigen::Matrix<double, 12, 1>;
  void add_position(const Eigen::Vector3d& p);
  void end_chain();
  void solve();

  double position_sigma_, bias_prior_sigma_, max_chain_time_, forget_time_;
  // Prior on (g, b) from earlier chains, information form (without the bias prior).
  Eigen::Matrix<double, 6, 6> prior_info_ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> prior_vec_ = Eigen::Matrix<double, 6, 1>::Zero();
  double support_time_ = 0;
  // The current chain: unknowns (p_0, v_0, g, b); integrals since its first frame.
  Mat12 H_ = Mat12::Zero();
  Vec12 r_ = Vec12::Zero();
  int chain_frames_ = 0;
  double chain_tau_ = 0;
  Eigen::Vector3d D_ = Eigen::Vector3d::Zero(), V_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d Jp_ = Eigen::Matrix3d::Zero(), Jv_ = Eigen::Matrix3d::Zero();
  // The solution.
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero(), bias_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gravity_sigma_, bias_sigma_;
};

/// Velocity of the IMU point in the world frame, filtered from tracked positions with either a
/// constant-velocity process or the accelerometer; and gravity in the world frame.
class VelocityFilter {
 public:
  VelocityFilter(const InertialConfig& config);

  struct Propagation {
    Eigen::Vector3d velocity_b = Eigen::Vector3d::Zero();
    Eigen::Vector3d delta_p = Eigen::Vector3d::Zero();  // IMU point displacement, world, m
    double delta_p_sigma = 0;                           // its 1 sigma per axis, m
    bool used_accelerometer = false;
    /// The accelerometer propagated a velocity known at least twice as well as one tracked
    /// frame pair measures it (four pairs' worth): an estimate independent of the next frame's
    /// tracking, not one pair's error carried forward.
    bool settled = false;
  };
  /// The motion over dt from the current velocity; the integration (specific force rotated into
  /// the world) is used when the model is the accelerometer, gravity is ready and `integration`
  /// is complete.
  Propagation propagate(double dt, const ImuIntegration* integration) const;

  /// Advances over a frame pair. p_a, p_b: tracked IMU-point positions (world, m); used as a
  /// measurement when `reliable`.
  void step(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b, bool reliable,
            const ImuIntegration* integration);

  bool has_velocity() const { return initialized_ && std::sqrt(P_) <= max_sigma_; }
  const Eigen::Vector3d& velocity() const { return v_; }
  double sigma() const {
    return initialized_ ? std::sqrt(P_) : std::numeric_limits<double>::infinity();
  }
  bool gravity_ready() const { return gravity_.support_time() >= gravity_min_time_; }
  const GravityBiasEstimator& gravity() const { return gravity_; }
  /// Forgets the velocity (a break in the frame chain); keeps gravity.
  void reset_velocity();
  /// Adds `dv` (world, m/s) to the velocity, where there is one.
  void correct_velocity(const Eigen::Vector3d& dv) {
    if (initialized_) v_ += dv;
  }
  /// Forgets velocity and gravity.
  void reset();
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  /// Variance of a velocity measured from two tracked positions dt apart, (m/s)^2 per axis.
  double pair_variance(double dt) const {
    return 2.0 * position_sigma_ * position_sigma_ / (dt * dt);
  }
  /// The filter's part of step(): propagation and, for a reliable pair, the measurement update.
  void update_velocity(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b,
                       bool reliable, const ImuIntegration* integration);
  /// Caps the speed at max_speed_ (the velocity's direction kept).
  void cap_speed();
  TranslationModel model_;
  double position_sigma_, cv_noise_, accel_noise_, max_sigma_;
  double accel_time_, decay_time_, max_speed_;
  double unmeasured_time_ = 0;  // s since the last tracked measurement of the velocity
  double gravity_min_time_;
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  double P_ = 0;  // velocity variance per axis, (m/s)^2
  bool initialized_ = false;
  GravityBiasEstimator gravity_;
};

}  // namespace imufusion::inertial
