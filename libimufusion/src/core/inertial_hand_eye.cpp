// Camera-IMU rotation from rotation pairs (hand-eye, rotation part). For each frame pair the
// tracked camera rotation R_c and the gyro rotation R_i satisfy R_c R_ci = R_ci R_i, so their
// rotation vectors satisfy a_c = R_ci a_i: an orthogonal Procrustes problem (Kabsch / SVD) in
// which each vector's length (the rotation angle) weighs its axis. The gyro bias enters a_i
// linearly (a_i(b) ~ a_i + Jr^-1 J_bias (b - b_used)), so it is solved jointly by alternation;
// otherwise a bias of 0.02 rad/s against ~0.5 rad/s of hand rotation tilts every axis by ~2 deg.

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "core/inertial_internal.hpp"

namespace imufusion::inertial {

namespace {
// Alternations of rotation and bias; the bias moves each a_i by < 1e-3 rad, so this converges
// in two or three (checked by the unit test's 0.2 deg recovery).
constexpr int kAlternations = 4;
}  // namespace

HandEyeCalibrator::HandEyeCalibrator(int max_pairs) : max_pairs_(max_pairs) {}

void HandEyeCalibrator::add(const Eigen::Matrix3d& R_camera_a_b, const ImuIntegration& integration) {
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
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();  // sum J^T J, for the bias solve
  for (const Pair& p : pairs_) A += p.J_bias.transpose() * p.J_bias;
  const Eigen::LDLT<Eigen::Matrix3d> A_ldlt(A);

  for (int iter = 0; iter < kAlternations; ++iter) {
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (const Pair& p : pairs_) M += p.a_camera * a_imu(p, out.gyro_bias).transpose();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Vector3d d(1, 1, 1);
    d.z() = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
    out.R_camera_imu = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
    // Bias: least squares of R^T a_c = a_i + J (b - b_used).
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    for (const Pair& p : pairs_) {
      r += p.J_bias.transpose() *
           (out.R_camera_imu.transpose() * p.a_camera - p.a_imu + p.J_bias * p.bias_used);
    }
    out.gyro_bias = A_ldlt.solve(r);
  }

  double sum_sq = 0;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs_) {
    const Eigen::Vector3d ai = a_imu(p, out.gyro_bias);
    sum_sq += (p.a_camera - out.R_camera_imu * ai).squaredNorm();
    scatter += ai * ai.transpose();
  }
  // 6 parameters: rotation and bias.
  const double var = sum_sq / std::max(1.0, 3.0 * static_cast<double>(pairs_.size()) - 6.0);
  out.bias_covariance = var * A_ldlt.solve(Eigen::Matrix3d::Identity());
  // Information about a rotation about unit axis u: sum |u x a_i|^2 / var, smallest for u along
  // the principal direction of the a_i: (lambda_min + lambda_mid) / var.
  const Eigen::Vector3d lambda = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  const double information = lambda[0] + lambda[1];
  if (information > 0) out.sigma = std::sqrt(var / information);
  return out;
}

}  // namespace imufusion::inertial
