// Translation between frames: a per-axis Kalman filter on the velocity of the IMU point in the
// world frame, measured by tracked positions and propagated either as constant (a random walk)
// or with the accelerometer (specific force, less its bias, rotated into the world, plus
// gravity). Gravity and the accelerometer bias come from GravityBiasEstimator. (The chain's
// least-squares end velocity was tried in place of the filter's: bench/inertial_models measured
// a worse frame-to-frame prediction, 0.45 against 0.34 mm median, and 0.70 against 0.40 mm on
// TUM fr1_xyz, for a dead-reckoning drift only 10% smaller.)

#include <cmath>

#include "core/inertial_internal.hpp"

namespace imufusion {

const char* to_string(TranslationModel model) {
  switch (model) {
    case TranslationModel::kNone:
      return "none";
    case TranslationModel::kConstantVelocity:
      return "constant-velocity";
    case TranslationModel::kAccelerometer:
      return "accelerometer";
  }
  return "unknown";
}

std::optional<TranslationModel> parse_translation_model(std::string_view name) {
  for (const TranslationModel m : {TranslationModel::kNone, TranslationModel::kConstantVelocity,
                                   TranslationModel::kAccelerometer}) {
    if (name == to_string(m)) return m;
  }
  return std::nullopt;
}

namespace inertial {

VelocityFilter::VelocityFilter(const InertialConfig& config)
    : model_(config.translation),
      position_sigma_(config.tracking_position_sigma),
      cv_noise_(config.constant_velocity_process_noise),
      accel_noise_(config.accelerometer_process_noise),
      max_sigma_(config.max_velocity_sigma),
      accel_time_(config.accelerometer_dead_reckoning_time),
      decay_time_(config.velocity_decay_time),
      max_speed_(config.max_speed),
      gravity_min_time_(config.gravity_min_time),
      gravity_(config.tracking_position_sigma, config.accelerometer_bias_prior_sigma,
               config.gravity_chain_time, config.gravity_time_constant) {}

VelocityFilter::Propagation VelocityFilter::propagate(double dt,
                                                      const ImuIntegration* integration) const {
  Propagation out;
  if (unmeasured_time_ >= accel_time_) {
    // Long untracked: the velocity decays to zero (exactly integrated over dt).
    const double keep = std::exp(-dt / decay_time_);
    out.velocity_b = v_ * keep;
    out.delta_p = v_ * decay_time_ * (1.0 - keep);
  } else if (model_ == TranslationModel::kAccelerometer && gravity_ready() &&
             integration != nullptr && integration->complete) {
    const Eigen::Vector3d& g = gravity_.gravity();
    const Eigen::Vector3d& b = gravity_.accel_bias();
    out.velocity_b = v_ + integration->delta_v - integration->Jv_accel * b + g * dt;
    out.delta_p = v_ * dt + integration->delta_p - integration->Jp_accel * b + 0.5 * g * dt * dt;
    out.used_accelerometer = true;
  } else {
    out.velocity_b = v_;
    out.delta_p = v_ * dt;
  }
  // The velocity's uncertainty over dt, and the random walk's: integral of a Wiener process,
  // variance q^2 dt^3 / 3.
  const double q = out.used_accelerometer ? accel_noise_ : cv_noise_;
  out.delta_p_sigma = std::sqrt(P_ * dt * dt + q * q * dt * dt * dt / 3.0);
  out.settled = out.used_accelerometer && initialized_ && 4.0 * P_ <= pair_variance(dt);
  return out;
}

void VelocityFilter::step(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b,
                          bool reliable, const ImuIntegration* integration) {
  if (!(dt > 0)) return;
  update_velocity(dt, p_a, p_b, reliable, integration);
  // Gravity and the bias learn from the pair after the velocity was propagated with them.
  gravity_.step(dt, p_a, p_b, reliable, integration);
}

void VelocityFilter::update_velocity(double dt, const Eigen::Vector3d& p_a,
                                     const Eigen::Vector3d& p_b, bool reliable,
                                     const ImuIntegration* integration) {
  const double measurement_var = pair_variance(dt);
  const Eigen::Vector3d mean_velocity = (p_b - p_a) / dt;
  if (!initialized_) {
    if (reliable) {
      v_ = mean_velocity;
      P_ = measurement_var;
      initialized_ = true;
    }
    return;
  }
  const Propagation prop = propagate(dt, integration);
  const double q = prop.used_accelerometer ? accel_noise_ : cv_noise_;
  const Eigen::Vector3d v_a = v_;
  v_ = prop.velocity_b;
  P_ += q * q * dt;
  if (!reliable) {
    unmeasured_time_ += dt;
    cap_speed();
    return;
  }
  unmeasured_time_ = 0;

  // The end velocity implied by the tracked displacement: with the accelerometer, the
  // displacement's shape within the pair is known (v_b = mean + dv - dp / dt); without it, the
  // mean velocity stands for the end velocity.
  Eigen::Vector3d z = mean_velocity;
  if (prop.used_accelerometer) {
    z += (prop.velocity_b - v_a) - (prop.delta_p - v_a * dt) / dt;
  }
  const double K = P_ / (P_ + measurement_var);
  v_ += K * (z - v_);
  P_ *= 1.0 - K;
  cap_speed();
}

void VelocityFilter::cap_speed() {
  const double speed = v_.norm();
  if (speed > max_speed_) v_ *= max_speed_ / speed;
}

void VelocityFilter::reset_velocity() {
  v_.setZero();
  P_ = 0;
  unmeasured_time_ = 0;
  initialized_ = false;
  gravity_.interrupt();
}

void VelocityFilter::reset() {
  reset_velocity();
  gravity_.reset();
}

void VelocityFilter::describe(StateArchive& archive) {
  archive(unmeasured_time_, v_, P_, initialized_, gravity_);
}

}  // namespace inertial
}  // namespace imufusion
