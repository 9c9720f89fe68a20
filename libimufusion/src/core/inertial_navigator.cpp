// InertialNavigator: the sample buffer, the calibration estimators (gyro bias, camera-IMU
// rotation) and the velocity filter behind one object, with the memory of the last tracked
// frame that the translation models start from.

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/inertial_internal.hpp"

namespace imufusion {

namespace {

// s: predict()/observe() start times within this of the remembered frame's time are that frame
// (frame stamps are microseconds; a 1 kHz IMU is 1 ms).
constexpr double kSameFrameTolerance = 1e-3;

Error config_error(const std::string& field, double value, const std::string& rule) {
  std::ostringstream os;
  os << "InertialConfig." << field << " = " << value << ": " << rule;
  return make_error(ErrorCode::kInvalidArgument, os.str());
}

}  // namespace

Status InertialConfig::validate() const {
  const Eigen::Matrix3d R = T_camera_imu.linear();
  if (!T_camera_imu.matrix().allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, "InertialConfig.T_camera_imu is not finite");
  }
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (orthogonality > 1e-6 || R.determinant() < 0) {
    return config_error("T_camera_imu (|R^T R - I|)", orthogonality,
                        "the rotation must be orthonormal with determinant +1");
  }
  if (!initial_gyro_bias.allFinite()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "InertialConfig.initial_gyro_bias is not finite");
  }
  if (!parse_translation_model(to_string(translation))) {
    return config_error("translation", static_cast<int>(translation), "not a TranslationModel");
  }
  const struct {
    const char* name;
    double value;
    bool zero_allowed;
  } positive[] = {
      {"max_extrapolation", max_extrapolation, true},
      {"max_sample_gap", max_sample_gap, false},
      {"sample_history", sample_history, false},
      {"gyro_bias_prior_sigma", gyro_bias_prior_sigma, false},
      {"gyro_bias_random_walk", gyro_bias_random_walk, true},
      {"gyro_noise_density", gyro_noise_density, true},
      {"icp_rotation_sigma", icp_rotation_sigma, false},
      {"hand_eye_max_sigma_deg", hand_eye_max_sigma_deg, false},
      {"mounting_check_deg", mounting_check_deg, false},
      {"tracking_position_sigma", tracking_position_sigma, false},
      {"constant_velocity_process_noise", constant_velocity_process_noise, true},
      {"accelerometer_process_noise", accelerometer_process_noise, true},
      {"max_velocity_sigma", max_velocity_sigma, false},
      {"accelerometer_dead_reckoning_time", accelerometer_dead_reckoning_time, true},
      {"velocity_decay_time", velocity_decay_time, false},
      {"max_speed", max_speed, false},
      {"gravity_min_time", gravity_min_time, true},
      {"gravity_time_constant", gravity_time_constant, false},
      {"gravity_chain_time", gravity_chain_time, false},
      {"accelerometer_bias_prior_sigma", accelerometer_bias_prior_sigma, false},
  };
  for (const auto& p : positive) {
    const bool ok = std::isfinite(p.value) && (p.zero_allowed ? p.value >= 0 : p.value > 0);
    if (!ok) return config_error(p.name, p.value, p.zero_allowed ? "must be >= 0" : "must be > 0");
  }
  if (hand_eye_min_pairs < 3) {
    return config_error("hand_eye_min_pairs", hand_eye_min_pairs, "must be >= 3");
  }
  if (hand_eye_max_pairs < hand_eye_min_pairs) {
    return config_error("hand_eye_max_pairs", hand_eye_max_pairs, "must be >= hand_eye_min_pairs");
  }
  return {};
}

struct InertialNavigator::State {
  explicit State(const InertialConfig& c)
      : config(c),
        samples(c.max_extrapolation, c.max_sample_gap, c.sample_history),
        bias(c.initial_gyro_bias, c.gyro_bias_prior_sigma, c.gyro_bias_random_walk,
             c.gyro_noise_density, c.icp_rotation_sigma),
        hand_eye(c.hand_eye_max_pairs),
        velocity(c),
        R_camera_imu(c.T_camera_imu.linear()),
        lever_arm(c.T_camera_imu_known ? Eigen::Vector3d(c.T_camera_imu.translation())
                                       : Eigen::Vector3d::Zero()),
        mounting_trusted(c.T_camera_imu_known),
        hand_eye_sigma(c.T_camera_imu_known ? 0.0 : std::numeric_limits<double>::infinity()) {}

  bool continues_last(double ta) const {
    return has_last && std::abs(ta - last_time) <= kSameFrameTolerance;
  }
  /// The IMU point (world, m) of a camera pose.
  Eigen::Vector3d imu_point(const Eigen::Isometry3d& T_world_camera) const {
    return T_world_camera.translation() + T_world_camera.linear() * lever_arm;
  }
  void observe_mounting(const Eigen::Matrix3d& R_camera_a_b,
                        const inertial::ImuIntegration& integration);

  InertialConfig config;
  inertial::SampleBuffer samples;
  inertial::GyroBiasEstimator bias;
  inertial::HandEyeCalibrator hand_eye;
  inertial::VelocityFilter velocity;
  Eigen::Matrix3d R_camera_imu;
  Eigen::Vector3d lever_arm;  // camera frame, m (translation of T_camera_imu)
  bool mounting_trusted;
  double hand_eye_sigma;  // rad
  /// The hand-eye estimate checking a given mounting, and its angle from it (rad).
  std::optional<Eigen::Matrix3d> R_camera_imu_check;
  double check_angle = 0;
  double check_sigma = 0;  // rad
  static constexpr int kCheckEveryPairs = 30;
  int pairs_since_check = kCheckEveryPairs;

  bool has_last = false;
  double last_time = 0;
  Eigen::Isometry3d T_world_last = Eigen::Isometry3d::Identity();
};

void InertialNavigator::State::observe_mounting(const Eigen::Matrix3d& R_camera_a_b,
                                                const inertial::ImuIntegration& integration) {
  hand_eye.add(R_camera_a_b, integration);
  if (hand_eye.pairs() < config.hand_eye_min_pairs) return;
  ++pairs_since_check;
  if (config.T_camera_imu_known && pairs_since_check < kCheckEveryPairs) return;
  pairs_since_check = 0;
  inertial::HandEyeCalibrator::Solution sol = hand_eye.solve(bias.bias());
  if (config.T_camera_imu_known) {
    // A given mounting stays in use; an estimate good to mounting_check_deg only checks it,
    // once per kCheckEveryPairs reliable pairs (the solve's cost is not needed every frame). A
    // wrong mounting also misleads the gyro bias learned with it (0.3 rad/s on the synthetic room
    // with its IMU given 180 deg off), and the solve started there fits worse than one started
    // at zero bias: the better fit of the two is kept.
    const inertial::HandEyeCalibrator::Solution from_zero = hand_eye.solve(Eigen::Vector3d::Zero());
    if (from_zero.sigma < sol.sigma) sol = from_zero;
    if (sol.sigma * 180.0 / std::numbers::pi > config.mounting_check_deg) return;
    R_camera_imu_check = sol.R_camera_imu;
    check_angle = Eigen::AngleAxisd(R_camera_imu.transpose() * sol.R_camera_imu).angle();
    check_sigma = sol.sigma;
    return;
  }
  hand_eye_sigma = sol.sigma;
  if (sol.sigma * 180.0 / std::numbers::pi > config.hand_eye_max_sigma_deg) return;
  if (!mounting_trusted && config.estimate_gyro_bias) {
    // The joint solve's bias starts the recursive estimator, which had no trusted mounting to
    // work with until now.
    bias.reset_to(sol.gyro_bias, sol.bias_covariance);
  }
  R_camera_imu = sol.R_camera_imu;
  mounting_trusted = true;
}

InertialNavigator::InertialNavigator(std::unique_ptr<State> state) : state_(std::move(state)) {}
InertialNavigator::InertialNavigator(InertialNavigator&&) noexcept = default;
InertialNavigator& InertialNavigator::operator=(InertialNavigator&&) noexcept = default;
InertialNavigator::~InertialNavigator() = default;

Result<InertialNavigator> InertialNavigator::create(const InertialConfig& config) {
  IMUFUSION_RETURN_IF_ERROR(config.validate());
  return InertialNavigator(std::make_unique<State>(config));
}

Status InertialNavigator::add_samples(std::span<const ImuSample> samples) {
  return state_->samples.append(samples);
}

double InertialNavigator::latest_sample_time() const { return state_->samples.latest_time(); }

bool InertialNavigator::covers(double t) const { return t <= state_->samples.latest_time(); }

MotionPrediction InertialNavigator::predict(double ta, double tb) const {
  const State& s = *state_;
  MotionPrediction out;
  if (!(tb >= ta) || !std::isfinite(ta) || !std::isfinite(tb)) return out;
  const bool continues = s.continues_last(ta);
  const Eigen::Matrix3d R_world_camera_a =
      continues ? Eigen::Matrix3d(s.T_world_last.linear()) : Eigen::Matrix3d::Identity();
  const inertial::ImuIntegration integration =
      s.samples.integrate(ta, tb, s.bias.bias(), R_world_camera_a * s.R_camera_imu);
  out.covered_fraction = integration.covered_fraction;
  out.samples_used = integration.samples_used;
  out.rotation_from_imu = integration.complete && s.mounting_trusted && !s.samples.empty();
  const Eigen::Matrix3d R_a_b =
      out.rotation_from_imu
          ? Eigen::Matrix3d(s.R_camera_imu * integration.R_a_b * s.R_camera_imu.transpose())
          : Eigen::Matrix3d::Identity();
  out.T_a_b.linear() = R_a_b;
  if (out.rotation_from_imu) {
    const double dt = tb - ta;
    const double bias_var = s.bias.covariance().trace() / 3.0;
    out.rotation_sigma = std::sqrt(s.config.gyro_noise_density * s.config.gyro_noise_density * dt +
                                   bias_var * dt * dt);
  }
  if (s.config.translation != TranslationModel::kNone && continues && s.velocity.has_velocity()) {
    const inertial::VelocityFilter::Propagation prop =
        s.velocity.propagate(tb - ta, out.rotation_from_imu ? &integration : nullptr);
    // Camera b relative to camera a, from the IMU point's displacement and the lever arm.
    out.T_a_b.translation() =
        s.lever_arm + R_world_camera_a.transpose() * prop.delta_p - R_a_b * s.lever_arm;
    out.translation_predicted = true;
    out.translation_sigma = prop.delta_p_sigma;
    out.translation_inertial = prop.settled;
  }
  return out;
}

void InertialNavigator::observe(double ta, double tb, const Eigen::Isometry3d& T_world_a,
                                const Eigen::Isometry3d& T_world_b, bool reliable) {
  State& s = *state_;
  if (!(tb > ta) || !T_world_a.matrix().allFinite() || !T_world_b.matrix().allFinite()) return;
  const double dt = tb - ta;
  const Eigen::Matrix3d R_camera_a_b = T_world_a.linear().transpose() * T_world_b.linear();
  const inertial::ImuIntegration integration =
      s.samples.integrate(ta, tb, s.bias.bias(), T_world_a.linear() * s.R_camera_imu);
  if (reliable && integration.complete) {
    s.observe_mounting(R_camera_a_b, integration);
    if (s.config.estimate_gyro_bias && s.mounting_trusted) {
      const Eigen::Matrix3d R_imu_icp = s.R_camera_imu.transpose() * R_camera_a_b * s.R_camera_imu;
      s.bias.update(tb, integration, R_imu_icp, dt, s.hand_eye_sigma);
    }
  }
  if (!s.continues_last(ta)) s.velocity.reset_velocity();
  const bool imu_usable = integration.complete && s.mounting_trusted;
  s.velocity.step(dt, s.imu_point(T_world_a), s.imu_point(T_world_b), reliable,
                  imu_usable ? &integration : nullptr);
  s.has_last = true;
  s.last_time = tb;
  s.T_world_last = T_world_b;
}

InertialStatus InertialNavigator::status() const {
  const State& s = *state_;
  InertialStatus out;
  out.gyro_bias = s.bias.bias();
  out.gyro_bias_sigma = s.bias.covariance().diagonal().cwiseSqrt();
  out.bias_updates = s.bias.updates();
  out.bias_rejected = s.bias.rejected();
  out.R_camera_imu = Eigen::Quaterniond(s.R_camera_imu);
  out.R_camera_imu_estimated = !s.config.T_camera_imu_known && s.mounting_trusted;
  out.R_camera_imu_sigma_deg = s.hand_eye_sigma * 180.0 / std::numbers::pi;
  out.hand_eye_pairs = s.hand_eye.pairs();
  if (s.R_camera_imu_check) {
    constexpr double kDeg = 180.0 / std::numbers::pi;
    out.R_camera_imu_check = Eigen::Quaterniond(*s.R_camera_imu_check);
    out.R_camera_imu_disagreement_deg = s.check_angle * kDeg;
    out.R_camera_imu_disagrees =
        s.check_angle * kDeg > std::max(s.config.mounting_check_deg, 3.0 * s.check_sigma * kDeg);
  }
  out.gravity_world = s.velocity.gravity().gravity();
  out.gravity_sigma = s.velocity.gravity().gravity_sigma();
  out.gravity_ready = s.velocity.gravity_ready();
  out.accel_bias = s.velocity.gravity().accel_bias();
  out.accel_bias_sigma = s.velocity.gravity().bias_sigma();
  out.velocity_world = s.velocity.velocity();
  out.velocity_sigma = s.velocity.sigma();
  return out;
}

void InertialNavigator::forget_velocity() { state_->velocity.reset_velocity(); }

void InertialNavigator::correct_velocity(const Eigen::Vector3d& dv) {
  state_->velocity.correct_velocity(dv);
}

void InertialNavigator::reset() {
  state_->has_last = false;
  state_->velocity.reset();
}

void InertialNavigator::describe(StateArchive& archive) {
  State& s = *state_;
  archive(s.samples, s.bias, s.hand_eye, s.velocity, s.R_camera_imu, s.lever_arm,
          s.mounting_trusted, s.hand_eye_sigma, s.R_camera_imu_check, s.check_angle, s.check_sigma,
          s.pairs_since_check, s.has_last, s.last_time, s.T_world_last);
}

}  // namespace imufusion
