// Camera-IMU rotation from rotation pairs (hand-eye, rotation part). For each frame pair the
// tracked camera rotation R_c and the gyro rotation R_i satisfy R_c R_ci = R_ci R_i, so their
// rotation vectors satisfy a_c = R_ci a_i: an orthogonal Procrustes problem (Kabsch / SVD) in
// which each vector's length (the rotation angle) weighs its axis. The gyro bias enters a_i
// linearly (a_i(b) ~ a_i + Jr^-1 J_bias (b - b_used)), so it is solved jointly; otherwise a bias of
// 0.02 rad/s against ~0.5 rad/s of hand rotation tilts every axis by ~2 deg.

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "core/inertial_internal.hpp"

namespace imufusion::inertial {

namespace {
// Gauss-Newton iterations after the Kabsch start; the problem is nearly linear (the start is
// within a few degrees), so 3 reach the minimum to < 1e-6 rad.
constexpr int kIterations = 3;

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

}  // namespace

HandEyeCalibrator::HandEyeCalibrator(int max_pairs) : max_pairs_(max_pairs) {}

void HandEyeCalibrator::add(const Eigen::Matrix3d& R_camera_a_b,
                            const ImuIntegration& integration) {
  Pair p;
  p.a_camera = log_so3(R_camera_a_b);
  p.a_imu = log_so3(integration.R_a_b);
  // d Log(R Exp(J d)) = Jr^-1(Log R) J d.
  p.J_bias = right_jacobian_so3(p.a_imu).inverse() * integration.J_bias;
  p.bias_used = integration.bias_used;
  pairs_.push_back(p);
  while (static_cast<int>(pairs_.size()) > max_pairs_) pairs_.pop_front();
}

HandEyeCalibrator::Solution HandEyeCalibrator::solve(const Eigen::Vector3d& bias_guess) const {
  Solution out;
  out.pairs = pairs();
  out.gyro_bias = bias_guess;
  out.sigma = std::numeric_limits<double>::infinity();
  if (pairs_.size() < 3) return out;

  const auto a_imu = [&](const Pair& p, const Eigen::Vector3d& b) -> Eigen::Vector3d {
    return p.a_imu + p.J_bias * (b - p.bias_used);
  };
  // Start: Kabsch with the bias guess.
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs_) M += p.a_camera * a_imu(p, out.gyro_bias).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d d(1, 1, 1);
  d.z() = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  out.R_camera_imu = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();

  // Then Gauss-Newton on rotation and bias together: a steady turn (walking round a room) makes
  // them correlated (a constant bias looks like a tilted turn axis), which alternating solves
  // would resolve only slowly. Residual r = a_c - Exp(dtheta) R a_i(b + db)
  //   ~ r + [R a_i]x dtheta - R J db.
  Matrix6d H = Matrix6d::Zero();
  double sum_sq = 0;
  for (int iter = 0; iter <= kIterations; ++iter) {
    H.setZero();
    Vector6d g = Vector6d::Zero();
    sum_sq = 0;
    for (const Pair& p : pairs_) {
      const Eigen::Vector3d v = out.R_camera_imu * a_imu(p, out.gyro_bias);
      const Eigen::Vector3d r = p.a_camera - v;
      Eigen::Matrix<double, 3, 6> G;
      G.leftCols<3>() = skew(v);
      G.rightCols<3>() = -out.R_camera_imu * p.J_bias;
      H += G.transpose() * G;
      g += G.transpose() * r;
      sum_sq += r.squaredNorm();
    }
    // A tiny damping keeps the step finite about an unexcited axis (the gradient has no
    // component there, so the step does not move along it).
    H.diagonal().array() += 1e-12 * (H.trace() / 6.0 + 1e-30);
    if (iter == kIterations) break;
    const Vector6d step = -H.ldlt().solve(g);
    out.R_camera_imu = exp_so3(step.head<3>()) * out.R_camera_imu;
    out.gyro_bias += step.tail<3>();
  }
  // 6 parameters: rotation and bias.
  const double var = sum_sq / std::max(1.0, 3.0 * static_cast<double>(pairs_.size()) - 6.0);
  const Matrix6d covariance = var * H.ldlt().solve(Matrix6d::Identity());
  out.bias_covariance = covariance.bottomRightCorner<3, 3>();
  // The rotation's standard deviation about its least constrained axis, with the bias's
  // correlation included.
  const Eigen::Vector3d lambda =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance.topLeftCorner<3, 3>())
          .eigenvalues();
  out.sigma = std::sqrt(std::max(0.0, lambda[2]));
  return out;
}

void HandEyeCalibrator::describe(StateArchive& archive) {
  std::size_t n = pairs_.size();
  archive(n);
  if (archive.reading()) {
    if (n > static_cast<std::size_t>(max_pairs_))
      archive.fail(std::to_string(n) + " hand-eye pairs, at most " + std::to_string(max_pairs_));
    pairs_.resize(archive.ok() ? n : 0);
  }
  for (Pair& p : pairs_) archive(p.a_camera, p.a_imu, p.J_bias, p.bias_used);
}

}  // namespace imufusion::inertial
