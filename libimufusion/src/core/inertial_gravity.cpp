// Gravity and accelerometer bias by position-level least squares over chains of tracked frames
// (see GravityBiasEstimator in inertial_internal.hpp). Unknown order: p_0, v_0, g, b.

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "core/inertial_internal.hpp"

namespace imufusion::inertial {

namespace {

// A chain needs three positions before it says anything about (g, b): two fix p_0 and v_0.
constexpr int kMinChainFrames = 3;

Eigen::Vector3d infinite3() {
  return Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
}

}  // namespace

GravityBiasEstimator::GravityBiasEstimator(double position_sigma, double bias_prior_sigma,
                                           double max_chain_time, double forget_time)
    : position_sigma_(position_sigma),
      bias_prior_sigma_(bias_prior_sigma),
      max_chain_time_(max_chain_time),
      forget_time_(forget_time),
      gravity_sigma_(infinite3()),
      bias_sigma_(Eigen::Vector3d::Constant(bias_prior_sigma)) {}

void GravityBiasEstimator::add_position(const Eigen::Vector3d& p) {
  // Rows of p_k = p_0 + v_0 tau + g tau^2 / 2 + D - J b, weighted by 1 / sigma^2.
  Eigen::Matrix<double, 3, 12> A;
  A << Eigen::Matrix3d::Identity(), chain_tau_ * Eigen::Matrix3d::Identity(),
      0.5 * chain_tau_ * chain_tau_ * Eigen::Matrix3d::Identity(), -Jp_;
  const double w = 1.0 / (position_sigma_ * position_sigma_);
  H_.noalias() += w * A.transpose() * A;
  r_.noalias() += w * A.transpose() * (p - D_);
  ++chain_frames_;
}

void GravityBiasEstimator::end_chain() {
  if (chain_frames_ >= kMinChainFrames) {
    // Marginalize p_0, v_0 (Schur complement) and keep what the chain says about (g, b).
    const Eigen::Matrix<double, 6, 6> Hnn = H_.topLeftCorner<6, 6>();
    const Eigen::Matrix<double, 6, 6> Hnt = H_.topRightCorner<6, 6>();
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(Hnn);
    if (ldlt.info() == Eigen::Success) {
      const double decay = std::exp(-chain_tau_ / forget_time_);
      prior_info_ =
          decay * prior_info_ + H_.bottomRightCorner<6, 6>() - Hnt.transpose() * ldlt.solve(Hnt);
      prior_vec_ = decay * prior_vec_ + r_.tail<6>() - Hnt.transpose() * ldlt.solve(r_.head<6>());
      support_time_ = decay * support_time_ + chain_tau_;
    }
  }
  H_.setZero();
  r_.setZero();
  chain_frames_ = 0;
  chain_tau_ = 0;
  D_.setZero();
  V_.setZero();
  Jp_.setZero();
  Jv_.setZero();
}

void GravityBiasEstimator::solve() {
  Mat12 H = H_;
  Vec12 r = r_;
  H.bottomRightCorner<6, 6>() += prior_info_;
  r.tail<6>() += prior_vec_;
  H.bottomRightCorner<3, 3>() +=
      Eigen::Matrix3d::Identity() / (bias_prior_sigma_ * bias_prior_sigma_);
  // p_0 and v_0 of a chain too short to fix them, and gravity before any information: a tiny
  // ridge keeps the system solvable; the covariance then shows them unknown.
  constexpr double kRidge = 1e-9;
  for (int i = 0; i < 9; ++i) H(i, i) += kRidge;
  const Eigen::LDLT<Mat12> ldlt(H);
  if (ldlt.info() != Eigen::Success) return;
  const Vec12 x = ldlt.solve(r);
  // The covariance's columns of (g, b): enough for their sigmas.
  const Eigen::Matrix<double, 12, 6> covariance = ldlt.solve(Mat12::Identity().rightCols<6>());
  if (!x.allFinite() || !covariance.allFinite()) return;
  // Only a chain with enough frames or an earlier chain's information determines gravity.
  const bool informed = chain_frames_ >= kMinChainFrames || support_time_ > 0;
  gravity_ = x.segment<3>(6);
  bias_ = x.tail<3>();
  gravity_sigma_ =
      informed ? Eigen::Vector3d(covariance.block<3, 3>(6, 0).diagonal().cwiseSqrt()) : infinite3();
  bias_sigma_ = covariance.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
}

void GravityBiasEstimator::step(double dt, const Eigen::Vector3d& p_a, const Eigen::Vector3d& p_b,
                                bool reliable, const ImuIntegration* integration) {
  if (!(dt > 0)) return;
  if (!reliable || integration == nullptr || !integration->complete) {
    interrupt();
    return;
  }
  if (chain_tau_ + dt > max_chain_time_ && chain_frames_ > 0) end_chain();
  if (chain_frames_ == 0) add_position(p_a);
  // The integrals restart at the chain's first frame; the pair's are relative to its start.
  D_ += V_ * dt + integration->delta_p;
  V_ += integration->delta_v;
  Jp_ += Jv_ * dt + integration->Jp_accel;
  Jv_ += integration->Jv_accel;
  chain_tau_ += dt;
  add_position(p_b);
  solve();
}

void GravityBiasEstimator::interrupt() {
  if (chain_frames_ == 0) return;
  end_chain();
  solve();
}

void GravityBiasEstimator::reset() {
  end_chain();
  prior_info_.setZero();
  prior_vec_.setZero();
  support_time_ = 0;
  gravity_.setZero();
  bias_.setZero();
  gravity_sigma_ = infinite3();
  bias_sigma_ = Eigen::Vector3d::Constant(bias_prior_sigma_);
}

void GravityBiasEstimator::describe(StateArchive& archive) {
  archive(prior_info_, prior_vec_, support_time_, H_, r_, chain_frames_, chain_tau_, D_, V_, Jp_,
          Jv_, gravity_, bias_, gravity_sigma_, bias_sigma_);
}

}  // namespace imufusion::inertial
