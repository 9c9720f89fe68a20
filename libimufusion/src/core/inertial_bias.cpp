// Online gyro bias: a Kalman filter on the constant (slowly drifting) bias. Each reliable frame
// pair gives the residual between the tracked rotation and the gyro integrated with the current
// bias, e = Log(R_gyro(b)^T R_icp), which is J_bias * (b_true - b) + noise to first order.

#include <cmath>

#include "core/inertial_internal.hpp"

namespace imufusion::inertial {

namespace {
// chi-square, 3 degrees of freedom, 99.9 %: a reliable pair whose residual is this unlikely is
// an ICP failure the reliability test missed, not information about the bias.
constexpr double kGateChi2 = 16.27;
}  // namespace

GyroBiasEstimator::GyroBiasEstimator(const Eigen::Vector3d& initial_bias, double prior_sigma,
                                     double random_walk, double noise_density, double icp_sigma)
    : bias_(initial_bias),
      P_(Eigen::Matrix3d::Identity() * prior_sigma * prior_sigma),
      random_walk_(random_walk),
      noise_density_(noise_density),
      icp_sigma_(icp_sigma) {}

bool GyroBiasEstimator::update(double t, const ImuIntegration& integration,
                               const Eigen::Matrix3d& R_imu_icp, double dt, double mounting_sigma) {
  if (has_time_ && t > last_time_) {
    P_ += Eigen::Matrix3d::Identity() * random_walk_ * random_walk_ * (t - last_time_);
  }
  last_time_ = t;
  has_time_ = true;

  const Eigen::Matrix3d& H = integration.J_bias;
  const Eigen::Matrix3d R_pred = integration.R_a_b * exp_so3(H * (bias_ - integration.bias_used));
  const Eigen::Vector3d e = log_so3(R_pred.transpose() * R_imu_icp);
  // Measurement noise: ICP error, integrated gyro white noise, and the mounting error, which
  // maps a rotation of angle theta wrong by ~theta * mounting_sigma.
  const double theta = log_so3(R_imu_icp).norm();
  const double var = icp_sigma_ * icp_sigma_ + noise_density_ * noise_density_ * dt +
                     theta * theta * mounting_sigma * mounting_sigma;
  const Eigen::Matrix3d S = H * P_ * H.transpose() + var * Eigen::Matrix3d::Identity();
  const Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
  if (e.dot(S_ldlt.solve(e)) > kGateChi2) {
    ++rejected_;
    return false;
  }
  const Eigen::Matrix3d K = S_ldlt.solve(H * P_).transpose();  // P H^T S^-1 (S, P symmetric)
  bias_ += K * e;
  // Joseph form keeps P symmetric positive definite.
  const Eigen::Matrix3d I_KH = Eigen::Matrix3d::Identity() - K * H;
  P_ = I_KH * P_ * I_KH.transpose() + var * K * K.transpose();
  ++updates_;
  return true;
}

void GyroBiasEstimator::reset_to(const Eigen::Vector3d& bias, const Eigen::Matrix3d& covariance) {
  bias_ = bias;
  P_ = 0.5 * (covariance + covariance.transpose());
}

void GyroBiasEstimator::describe(StateArchive& archive) {
  archive(bias_, P_, last_time_, has_time_, updates_, rejected_);
}

}  // namespace imufusion::inertial
