#include "core/drift_model.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

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

DriftFit fit_drift(const std::vector<StretchFrame>& frames, double T, const Eigen::Vector3d& end_translation,
                   const Eigen::Vector3d& end_rotation, const DriftPrior& prior) {
  DriftFit result;
  std::vector<StretchCorrection>& out = result.corrections;
  out.assign(frames.size(), StretchCorrection{end_translation, end_rotation});
  if (!(T > 0)) return result;
  // The Gaussian unknowns z: gyro bias error (3, camera frame), start velocity error (3),
  // gravity error (3), accelerometer bias error (3, camera frame), then the gyro noise's rotation
  // increment over each interval between frames (3 each). Their prior covariance Sigma is
  // diagonal but for the (gravity, bias) block.
  constexpr Eigen::Index kGyroBias = 0, kVelocity = 3, kGravity = 6, kAccelBias = 9, kNoise = 12;
  const std::size_t intervals = frames.size() + 1;
  const Eigen::Index n = kNoise + static_cast<Eigen::Index>(3 * intervals);
  const auto noise_index = [](std::size_t k) { return kNoise + static_cast<Eigen::Index>(3 * k); };
  const auto interval_end = [&](std::size_t k) {
    return k < frames.size() ? std::clamp(frames[k].s, 0.0, T) : T;
  };
  const auto orientation = [&](std::size_t k) -> Eigen::Matrix3d {
    if (frames.empty()) return Eigen::Matrix3d::Identity();
    return frames[std::min(k, frames.size() - 1)].R_world_camera;
  };
  // A sigma that is not finite (nothing measured yet: the velocity before the scan's second
  // tracked frame) leaves that error free. Its variance is taken as 1 ((rad/s)^2, (m/s)^2), far
  // above any estimate's, where the conditional mean is that of a free error: an infinite one
  // would turn Sigma H^T into inf * 0.
  const auto free_if_unknown = [](double sigma) { return std::isfinite(sigma) ? sigma * sigma : 1.0; };
  double gyro_bias2 = free_if_unknown(prior.gyro_bias_sigma);
  const double noise2 = prior.gyro_noise_density * prior.gyro_noise_density;
  if (!(gyro_bias2 + noise2 > 0)) gyro_bias2 = 1;  // linear
  double velocity2 = free_if_unknown(prior.velocity_sigma);
  const bool accelerometer = prior.gravity_bias_covariance.allFinite() && prior.gravity_bias_covariance.trace() > 0;
  if (!(velocity2 > 0) && !accelerometer) velocity2 = 1;  // linear
  Eigen::VectorXd variance = Eigen::VectorXd::Zero(n);  // Sigma's diagonal, the block apart
  variance.segment<3>(kGyroBias).setConstant(gyro_bias2);
  variance.segment<3>(kVelocity).setConstant(velocity2);
  double previous = 0;
  for (std::size_t k = 0; k < intervals; ++k) {
    const double end = std::max(previous, interval_end(k));
    variance.segment<3>(noise_index(k)).setConstant(noise2 * (end - previous));
    previous = end;
  }

  // A frame placed with a measured move (moved_sigma > 0) moved the estimate: the error drops
  // by the move there, and its fixed directions are not taken as exact. The move is a
  // measurement of the error just before it, taken only while it agrees with the rest (below).
  const auto measured_move = [&](std::size_t k) { return frames[k].moved_sigma > 0; };
  const auto reset = [&](std::size_t k) -> Eigen::Matrix3d {
    return measured_move(k) ? Eigen::Matrix3d::Zero() : frames[k].fixed;
  };

  // One interval of the error dynamics, on any affine function of z (3 x (n + 1) maps, the last
  // column the constant term) or on values (3 x 1): the rotation error moves by the bias error
  // and the noise increment, the acceleration is constant at its midpoint value.
  const Eigen::Matrix3d g_cross = skew(prior.gravity_world);
  const auto run = [&](auto& rotation, auto& position, auto& velocity, const auto& bias, const auto& accel_bias,
                       const auto& gravity, const auto& noise_of, auto&& at_move, auto&& at_frame) {
    double last = 0;
    for (std::size_t k = 0; k < intervals; ++k) {
      const double end = std::max(last, interval_end(k));
      const double h = end - last;
      const Eigen::Matrix3d R = orientation(k);
      const auto step = (R * bias * h + noise_of(k)).eval();
      // -delta x g = g x delta
      const auto acceleration = (g_cross * (rotation + 0.5 * step) + R * accel_bias + gravity).eval();
      position += velocity * h + 0.5 * h * h * acceleration;
      velocity += acceleration * h;
      rotation += step;
      if (k < frames.size()) {
        if (measured_move(k)) at_move(k, position);
        position = (Eigen::Matrix3d::Identity() - reset(k)) * position;
        at_frame(k);
      }
      last = end;
    }
  };
  const Eigen::Index constant = n;
  const auto unknown = [&](Eigen::Index first) {
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(3, n + 1);
    m.middleCols<3>(first).setIdentity();
    return m;
  };

  // The directions frame k fixed that the frame before it did not: more than 45 degrees from
  // the span the frame before fixed (the anchor fixed all).
  const auto newly_fixed = [&](std::size_t k) -> Eigen::Matrix3d {
    const Eigen::Matrix3d& P = frames[k].fixed;
    const Eigen::Matrix3d before = k == 0 ? Eigen::Matrix3d::Identity() : frames[k - 1].fixed;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(P - P * before * P);
    Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
    for (int i = 0; i < 3; ++i)
      if (eig.eigenvalues()(i) > 0.5) N += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
    return N;
  };

  // The measurements, affine in z, from one run: the end error (6 rows, exact), the errors of
  // the frames observed (3 rows each, always taken), then for each measured move along newly
  // fixed directions (in time order) the error just before it along them (3 rows). Which moves
  // are taken changes only which rows a fit uses.
  struct Move {
    Eigen::MatrixXd A;  // 3 x (n + 1)
    Eigen::Vector3d y;
    Eigen::Matrix3d noise;
  };
  std::vector<Move> moves, observations;  // the observations always taken
  Eigen::MatrixXd end_A(6, n + 1);
  {
    Eigen::MatrixXd rotation = Eigen::MatrixXd::Zero(3, n + 1), position = Eigen::MatrixXd::Zero(3, n + 1),
                    velocity = unknown(kVelocity);
    run(rotation, position, velocity, unknown(kGyroBias), unknown(kAccelBias), unknown(kGravity),
        [&](std::size_t k) { return unknown(noise_index(k)); },
        [&](std::size_t k, Eigen::MatrixXd& p) {
          const Eigen::Matrix3d N = newly_fixed(k);
          if (N.trace() >= 0.5)
            moves.push_back({N * p, N * frames[k].moved, N * (frames[k].moved_sigma * frames[k].moved_sigma)});
          p.col(constant) -= frames[k].moved;
        },
        [&](std::size_t k) {
          const double sigma = frames[k].observed_sigma;
          if (sigma > 0)
            observations.push_back({position, frames[k].observed, Eigen::Matrix3d::Identity() * (sigma * sigma)});
        });
    end_A << rotation, position;
  }
  Eigen::Matrix<double, 6, 1> end_y;
  end_y << end_rotation, end_translation;

  // The conditional mean of z given the end error and the moves taken, with the chi-square of
  // those measurements and its degrees of freedom.
  struct Fit {
    Eigen::VectorXd z;
    double chi2 = 0;
    Eigen::Index dof = 0;
  };
  std::vector<char> taken(moves.size(), 0);
  const auto fit = [&]() {
    const Eigen::Index m =
        6 + 3 * static_cast<Eigen::Index>(observations.size() + std::count(taken.begin(), taken.end(), 1));
    Eigen::MatrixXd A(m, n + 1);
    Eigen::VectorXd y(m);
    Eigen::MatrixXd noise = Eigen::MatrixXd::Zero(m, m);
    A.topRows<6>() = end_A;
    y.head<6>() = end_y;
    Eigen::Index row = 6;
    const auto add = [&](const Move& measurement) {
      A.middleRows<3>(row) = measurement.A;
      y.segment<3>(row) = measurement.y;
      noise.block<3, 3>(row, row) = measurement.noise;
      row += 3;
    };
    for (const Move& observation : observations) add(observation);
    for (std::size_t j = 0; j < moves.size(); ++j)
      if (taken[j]) add(moves[j]);
    y -= A.col(constant);
    const Eigen::MatrixXd H = A.leftCols(n);
    Eigen::MatrixXd cross = variance.asDiagonal() * H.transpose();  // Sigma H^T
    if (accelerometer)
      cross.middleRows<6>(kGravity) = prior.gravity_bias_covariance * H.transpose().middleRows<6>(kGravity);
    const Eigen::MatrixXd S = H * cross + noise;
    const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(S);
    const Eigen::VectorXd w = cod.solve(y);
    return Fit{cross * w, y.dot(w), cod.rank()};
  };

  // The moves are taken in time order, each while the chi-square grows by no more than its
  // 99.9th percentile for the degrees of freedom the move adds: a partial alignment that
  // settled on the wrong stretch of the model contradicts the end error and is left out.
  Fit best = fit();
  for (std::size_t j = 0; j < moves.size(); ++j) {
    taken[j] = 1;
    Fit trial = fit();
    static constexpr double kChi2[] = {10.83, 13.82, 16.27};  // 99.9th percentile, 1-3 dof
    const double limit = kChi2[std::clamp<Eigen::Index>(trial.dof - best.dof, 1, 3) - 1];
    if (trial.chi2 - best.chi2 <= limit)
      best = std::move(trial);
    else
      taken[j] = 0;
  }
  const Eigen::VectorXd& z = best.z;

  // The frames' errors at the conditional mean of z.
  Eigen::Vector3d r = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = z.segment<3>(kVelocity);
  run(r, p, v, Eigen::Vector3d(z.segment<3>(kGyroBias)), Eigen::Vector3d(z.segment<3>(kAccelBias)),
      Eigen::Vector3d(z.segment<3>(kGravity)),
      [&](std::size_t k) -> Eigen::Vector3d { return z.segment<3>(noise_index(k)); },
      [&](std::size_t k, Eigen::Vector3d& position) { position -= frames[k].moved; },
      [&](std::size_t k) { out[k] = StretchCorrection{p, r}; });
  result.end_velocity = v;
  result.chi2 = best.chi2;
  result.dof = best.dof;
  return result;
}

}  // namespace

std::vector<StretchCorrection> drift_corrections(const std::vector<StretchFrame>& frames, double T,
                                                 const Eigen::Vector3d& end_translation,
                                                 const Eigen::Vector3d& end_rotation, const DriftPrior& prior) {
  return fit_drift(frames, T, end_translation, end_rotation, prior).corrections;
}

std::optional<Eigen::Vector3d> drift_end_velocity(const std::vector<StretchFrame>& frames, double T,
                                                  const Eigen::Vector3d& end_translation,
                                                  const Eigen::Vector3d& end_rotation, const DriftPrior& prior) {
  if (!(T > 0)) return std::nullopt;
  const DriftFit fit = fit_drift(frames, T, end_translation, end_rotation, prior);
  if (fit.chi2 > chi_square_999(fit.dof)) return std::nullopt;
  return fit.end_velocity;
}

}  // namespace imufusion
