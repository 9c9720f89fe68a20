#include "core/drift_model.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "core/so3.hpp"

namespace imufusion {

namespace {

// The chi-square distribution's 99.9th percentile for `dof` degrees of freedom (Wilson and
// Hilferty's cube-root normal approximation: 22.7 for 6, where the exact value is 22.5).
double chi_square_999(Eigen::Index dof) {
  if (dof <= 0) return 0;
  const double k = static_cast<double>(dof), z = 3.0902;  // the normal's 99.9th percentile
  const double c = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
  return k * c * c * c;
}

// drift_corrections and drift_end_velocity: the frames' corrections and the velocity error at T.
struct DriftFit {
  std::vector<StretchCorrection> corrections;
  Eigen::Vector3d end_velocity = Eigen::Vector3d::Zero();
  double chi2 = 0;  // of the end error and the measurements taken, under the prior
  Eigen::Index dof = 0;
};

// The linear model of a stretch's errors. The Gaussian unknowns z: gyro bias error (3, camera
// frame), start velocity error (3), gravity error (3), accelerometer bias error (3, camera
// frame), then the gyro noise's rotation increment over each interval between frames (3 each).
// Their prior covariance Sigma is diagonal but for the (gravity, bias) block.
class DriftModel {
 public:
  static constexpr Eigen::Index kGyroBias = 0, kVelocity = 3, kGravity = 6, kAccelBias = 9,
                                kNoise = 12;

  DriftModel(const std::vector<StretchFrame>& frames, double T, const DriftPrior& prior)
      : frames_(frames),
        T_(T),
        prior_(prior),
        intervals_(frames.size() + 1),
        n_(kNoise + static_cast<Eigen::Index>(3 * intervals_)),
        g_cross_(skew(prior.gravity_world)) {
    set_prior_variance();
  }

  // A measurement affine in z: rows A (3 x (n + 1), the last column the constant term) of value
  // y with noise covariance `noise`.
  struct Measurement {
    Eigen::MatrixXd A;
    Eigen::Vector3d y;
    Eigen::Matrix3d noise;
  };
  // The measurements from one run: the end error (6 rows, exact), the errors of the frames
  // observed (always taken), then for each measured move along newly fixed directions (in time
  // order) the error just before it along them. Which moves are taken changes only which rows
  // a fit uses.
  void collect(std::vector<Measurement>& moves, std::vector<Measurement>& observations,
               Eigen::MatrixXd& end_A) const;

  // The conditional mean of z given the end error `end_y` (rotation, translation), the
  // observations and the moves `taken`, with the chi-square of those measurements and its
  // degrees of freedom.
  struct Fit {
    Eigen::VectorXd z;
    double chi2 = 0;
    Eigen::Index dof = 0;
  };
  Fit fit(const Eigen::MatrixXd& end_A, const Eigen::Matrix<double, 6, 1>& end_y,
          const std::vector<Measurement>& observations, const std::vector<Measurement>& moves,
          const std::vector<char>& taken) const;

  // The frames' errors (and the velocity error at T) at the values z.
  Eigen::Vector3d corrections_at(const Eigen::VectorXd& z,
                                 std::vector<StretchCorrection>& out) const;

 private:
  Eigen::Index noise_index(std::size_t k) const {
    return kNoise + static_cast<Eigen::Index>(3 * k);
  }
  double interval_end(std::size_t k) const {
    return k < frames_.size() ? std::clamp(frames_[k].s, 0.0, T_) : T_;
  }
  Eigen::Matrix3d orientation(std::size_t k) const {
    if (frames_.empty()) return Eigen::Matrix3d::Identity();
    return frames_[std::min(k, frames_.size() - 1)].R_world_camera;
  }
  // A frame placed with a measured move (moved_sigma > 0) moved the estimate: the error drops
  // by the move there, and its fixed directions are not taken as exact. The move is a
  // measurement of the error just before it, taken only while it agrees with the rest.
  bool measured_move(std::size_t k) const { return frames_[k].moved_sigma > 0; }
  Eigen::Matrix3d reset(std::size_t k) const {
    return measured_move(k) ? Eigen::Matrix3d::Zero() : frames_[k].fixed;
  }
  Eigen::MatrixXd unknown(Eigen::Index first) const {
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(3, n_ + 1);
    m.middleCols<3>(first).setIdentity();
    return m;
  }
  // The directions frame k fixed that the frame before it did not: more than 45 degrees from
  // the span the frame before fixed (the anchor fixed all).
  Eigen::Matrix3d newly_fixed(std::size_t k) const;
  void set_prior_variance();

  // One run of the error dynamics over the intervals, on any affine function of z (3 x (n + 1)
  // maps) or on values (3 x 1): the rotation error moves by the bias error and the noise
  // increment, the acceleration is constant at its midpoint value.
  template <typename M, typename V, typename NoiseOf, typename AtTurn, typename AtMove,
            typename AtFrame>
  void run(M& rotation, M& position, M& velocity, const V& bias, const V& accel_bias,
           const V& gravity, const NoiseOf& noise_of, AtTurn&& at_turn, AtMove&& at_move,
           AtFrame&& at_frame) const {
    double last = 0;
    for (std::size_t k = 0; k < intervals_; ++k) {
      const double end = std::max(last, interval_end(k));
      const double h = end - last;
      const Eigen::Matrix3d R = orientation(k);
      const auto step = (R * bias * h + noise_of(k)).eval();
      // -delta x g = g x delta
      const auto acceleration =
          (g_cross_ * (rotation + 0.5 * step) + R * accel_bias + gravity).eval();
      position += velocity * h + 0.5 * h * h * acceleration;
      velocity += acceleration * h;
      rotation += step;
      if (k < frames_.size()) {
        at_turn(k, rotation);
        if (measured_move(k)) at_move(k, position);
        position = (Eigen::Matrix3d::Identity() - reset(k)) * position;
        at_frame(k);
      }
      last = end;
    }
  }

  const std::vector<StretchFrame>& frames_;
  double T_;
  const DriftPrior& prior_;
  std::size_t intervals_;
  Eigen::Index n_;
  Eigen::Matrix3d g_cross_;
  Eigen::VectorXd variance_;  // Sigma's diagonal, the (gravity, bias) block apart
  bool accelerometer_ = false;
};

void DriftModel::set_prior_variance() {
  // A sigma that is not finite (nothing measured yet: the velocity before the scan's second
  // tracked frame) leaves that error free. Its variance is taken as 1 ((rad/s)^2, (m/s)^2), far
  // above any estimate's, where the conditional mean is that of a free error: an infinite one
  // would turn Sigma H^T into inf * 0.
  const auto free_if_unknown = [](double sigma) {
    return std::isfinite(sigma) ? sigma * sigma : 1.0;
  };
  double gyro_bias2 = free_if_unknown(prior_.gyro_bias_sigma);
  const double noise2 = prior_.gyro_noise_density * prior_.gyro_noise_density;
  if (!(gyro_bias2 + noise2 > 0)) gyro_bias2 = 1;  // linear
  double velocity2 = free_if_unknown(prior_.velocity_sigma);
  accelerometer_ =
      prior_.gravity_bias_covariance.allFinite() && prior_.gravity_bias_covariance.trace() > 0;
  if (!(velocity2 > 0) && !accelerometer_) velocity2 = 1;  // linear
  variance_ = Eigen::VectorXd::Zero(n_);
  variance_.segment<3>(kGyroBias).setConstant(gyro_bias2);
  variance_.segment<3>(kVelocity).setConstant(velocity2);
  double previous = 0;
  for (std::size_t k = 0; k < intervals_; ++k) {
    const double end = std::max(previous, interval_end(k));
    variance_.segment<3>(noise_index(k)).setConstant(noise2 * (end - previous));
    previous = end;
  }
}

Eigen::Matrix3d DriftModel::newly_fixed(std::size_t k) const {
  const Eigen::Matrix3d& P = frames_[k].fixed;
  const Eigen::Matrix3d before = k == 0 ? Eigen::Matrix3d::Identity() : frames_[k - 1].fixed;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(P - P * before * P);
  Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i)
    if (eig.eigenvalues()(i) > 0.5)
      N += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
  return N;
}

void DriftModel::collect(std::vector<Measurement>& moves, std::vector<Measurement>& observations,
                         Eigen::MatrixXd& end_A) const {
  const Eigen::Index constant = n_;
  Eigen::MatrixXd rotation = Eigen::MatrixXd::Zero(3, n_ + 1),
                  position = Eigen::MatrixXd::Zero(3, n_ + 1), velocity = unknown(kVelocity);
  run(
      rotation, position, velocity, unknown(kGyroBias), unknown(kAccelBias), unknown(kGravity),
      [&](std::size_t k) { return unknown(noise_index(k)); },
      [&](std::size_t k, Eigen::MatrixXd& r) { r.col(constant) -= frames_[k].turned; },
      [&](std::size_t k, Eigen::MatrixXd& p) {
        const Eigen::Matrix3d N = newly_fixed(k);
        if (N.trace() >= 0.5)
          moves.push_back(
              {N * p, N * frames_[k].moved, N * (frames_[k].moved_sigma * frames_[k].moved_sigma)});
        p.col(constant) -= frames_[k].moved;
      },
      [&](std::size_t k) {
        const double sigma = frames_[k].observed_sigma;
        if (sigma > 0)
          observations.push_back(
              {position, frames_[k].observed, Eigen::Matrix3d::Identity() * (sigma * sigma)});
      });
  end_A.resize(6, n_ + 1);
  end_A << rotation, position;
}

DriftModel::Fit DriftModel::fit(const Eigen::MatrixXd& end_A,
                                const Eigen::Matrix<double, 6, 1>& end_y,
                                const std::vector<Measurement>& observations,
                                const std::vector<Measurement>& moves,
                                const std::vector<char>& taken) const {
  const Eigen::Index m =
      6 + 3 * static_cast<Eigen::Index>(observations.size() +
                                        std::count(taken.begin(), taken.end(), 1));
  Eigen::MatrixXd A(m, n_ + 1);
  Eigen::VectorXd y(m);
  Eigen::MatrixXd noise = Eigen::MatrixXd::Zero(m, m);
  A.topRows<6>() = end_A;
  y.head<6>() = end_y;
  Eigen::Index row = 6;
  const auto add = [&](const Measurement& measurement) {
    A.middleRows<3>(row) = measurement.A;
    y.segment<3>(row) = measurement.y;
    noise.block<3, 3>(row, row) = measurement.noise;
    row += 3;
  };
  for (const Measurement& observation : observations) add(observation);
  for (std::size_t j = 0; j < moves.size(); ++j)
    if (taken[j]) add(moves[j]);
  y -= A.col(n_);
  const Eigen::MatrixXd H = A.leftCols(n_);
  Eigen::MatrixXd cross = variance_.asDiagonal() * H.transpose();  // Sigma H^T
  if (accelerometer_)
    cross.middleRows<6>(kGravity) =
        prior_.gravity_bias_covariance * H.transpose().middleRows<6>(kGravity);
  const Eigen::MatrixXd S = H * cross + noise;
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(S);
  const Eigen::VectorXd w = cod.solve(y);
  return Fit{cross * w, y.dot(w), cod.rank()};
}

Eigen::Vector3d DriftModel::corrections_at(const Eigen::VectorXd& z,
                                           std::vector<StretchCorrection>& out) const {
  Eigen::Vector3d r = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = z.segment<3>(kVelocity);
  run(
      r, p, v, Eigen::Vector3d(z.segment<3>(kGyroBias)), Eigen::Vector3d(z.segment<3>(kAccelBias)),
      Eigen::Vector3d(z.segment<3>(kGravity)),
      [&](std::size_t k) -> Eigen::Vector3d { return z.segment<3>(noise_index(k)); },
      [&](std::size_t k, Eigen::Vector3d& rotation) { rotation -= frames_[k].turned; },
      [&](std::size_t k, Eigen::Vector3d& position) { position -= frames_[k].moved; },
      [&](std::size_t k) {
        out[k] = StretchCorrection{p, r};
      });
  return v;
}

DriftFit fit_drift(const std::vector<StretchFrame>& frames, double T,
                   const Eigen::Vector3d& end_translation, const Eigen::Vector3d& end_rotation,
                   const DriftPrior& prior) {
  DriftFit result;
  result.corrections.assign(frames.size(), StretchCorrection{end_translation, end_rotation});
  if (!(T > 0)) return result;
  const DriftModel model(frames, T, prior);
  std::vector<DriftModel::Measurement> moves, observations;
  Eigen::MatrixXd end_A;
  model.collect(moves, observations, end_A);
  Eigen::Matrix<double, 6, 1> end_y;
  end_y << end_rotation, end_translation;
  // The moves are taken in time order, each while the chi-square grows by no more than its
  // 99.9th percentile for the degrees of freedom the move adds: a partial alignment that
  // settled on the wrong stretch of the model contradicts the end error and is left out.
  std::vector<char> taken(moves.size(), 0);
  DriftModel::Fit best = model.fit(end_A, end_y, observations, moves, taken);
  for (std::size_t j = 0; j < moves.size(); ++j) {
    taken[j] = 1;
    DriftModel::Fit trial = model.fit(end_A, end_y, observations, moves, taken);
    static constexpr double kChi2[] = {10.83, 13.82, 16.27};  // 99.9th percentile, 1-3 dof
    const double limit = kChi2[std::clamp<Eigen::Index>(trial.dof - best.dof, 1, 3) - 1];
    if (trial.chi2 - best.chi2 <= limit)
      best = std::move(trial);
    else
      taken[j] = 0;
  }
  result.end_velocity = model.corrections_at(best.z, result.corrections);
  result.chi2 = best.chi2;
  result.dof = best.dof;
  return result;
}

}  // namespace

std::vector<StretchCorrection> drift_corrections(const std::vector<StretchFrame>& frames, double T,
                                                 const Eigen::Vector3d& end_translation,
                                                 const Eigen::Vector3d& end_rotation,
                                                 const DriftPrior& prior) {
  return fit_drift(frames, T, end_translation, end_rotation, prior).corrections;
}

std::optional<Eigen::Vector3d> drift_end_velocity(const std::vector<StretchFrame>& frames, double T,
                                                  const Eigen::Vector3d& end_translation,
                                                  const Eigen::Vector3d& end_rotation,
                                                  const DriftPrior& prior) {
  if (!(T > 0)) return std::nullopt;
  const DriftFit fit = fit_drift(frames, T, end_translation, end_rotation, prior);
  if (fit.chi2 > chi_square_999(fit.dof)) return std::nullopt;
  return fit.end_velocity;
}

}  // namespace imufusion
