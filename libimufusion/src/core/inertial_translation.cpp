// Translation between frames: a per-axis Kalman filter on the velocity of the IMU point in the
// world frame, measured by tracked positions and propagated either as constant (a random walk)
// or with the accelerometer (specific force rotated into the world plus gravity). Gravity in the
// world frame comes from consecutive tracked pairs and the specific force between them.

#include <cmath>

#include "core/inertial_internal.hpp"

namespace imufusion {

const char* to_string(TranslationModel model) {
  switch (model) {
    case TranslationModel::kNone: return "none";
    case TranslationModel::kConstantVelocity: return "constant-velocity";
    case TranslationModel::kAccelerometer: return "accelerometer";
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
      gravity_min_time_(config.gravity_min_time),
      gravity_tau_(config.gravity_time_constant) {}

VelocityFilter::Propagation VelocityFilter::propagate(double dt,
                                                      const ImuIntegration* integration) const {
  Propagation out;
  if (model_ == TranslationModel::kAccelerometer && gravity_ready() && integration != nullptr &&
      integration->complete) {
    const Eigen::Vector3d g = gravity();
    out.velocity_b = v_ + integration->delta_v + g * dt;
    out.delta_p = v_ * dt + integration->delta_p + 0.5 * g * dt * dt;
    out.used_accelerometer = true;
  } else {
    out.velocity_b = v_;
    out.delta_p = v_ * dt;
  }
  return out;
}

void VelocityFilter::step(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b,
                          bool reliable, const ImuIntegration* integration) {
  if (!(dt > 0)) return;
  // Variance of a velocity from two positions dt apart.
  const double measurement_var = 2.0 * position_sigma_ * position_sigma_ / (dt * dt);
  const Eigen::Vector3d mean_velocity = (p_b - p_a) / dt;
  if (!initialized_) {
    if (reliable) {
      v_ = mean_velocity;
      P_ = measurement_var;
      initialized_ = true;
      observe_gravity(dt, p_b - p_a, integration);
    }
    return;
  }
  const Propagation prop = propagate(dt, integration);
  const double q = prop.used_accelerometer ? accel_noise_ : cv_noise_;
  const Eigen::Vector3d v_a = v_;
  v_ = prop.velocity_b;
  P_ += q * q * dt;
  if (!reliable) {
    has_previous_pair_ = false;
    return;
  }

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

  observe_gravity(dt, p_b - p_a, integration);
}

void VelocityFilter::observe_gravity(double dt, const Eigen::Vector3d& displacement,
                                     const ImuIntegration* integration) {
  if (integration == nullptr || !integration->complete) {
    has_previous_pair_ = false;
    return;
  }
  // Over two consecutive tracked pairs (dt1, dt2), with u = (displacement - delta_p) / dt the
  // mean velocity less the specific force's share: g (dt1 + dt2) / 2 = u2 - u1 - delta_v1.
  // Exact for any motion; summed over many pairs the u terms telescope, so tracking noise
  // enters only through the first and last pair.
  const Eigen::Vector3d u = (displacement - integration->delta_p) / dt;
  if (has_previous_pair_) {
    const double weight = 0.5 * (previous_dt_ + dt);
    const double decay = std::exp(-weight / gravity_tau_);
    gravity_sum_ = decay * gravity_sum_ + (u - previous_u_ - previous_delta_v_);
    gravity_time_ = decay * gravity_time_ + weight;
  }
  previous_u_ = u;
  previous_delta_v_ = integration->delta_v;
  previous_dt_ = dt;
  has_previous_pair_ = true;
}

Eigen::Vector3d VelocityFilter::gravity() const {
  return gravity_time_ > 0 ? Eigen::Vector3d(gravity_sum_ / gravity_time_)
                           : Eigen::Vector3d::Zero();
}

void VelocityFilter::reset_velocity() {
  v_.setZero();
  P_ = 0;
  initialized_ = false;
  has_previous_pair_ = false;
}

void VelocityFilter::reset() {
  reset_velocity();
  gravity_sum_.setZero();
  gravity_time_ = 0;
}

}  // namespace inertial
}  // namespace imufusion
