#include "imufusion/icp.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "core/so3.hpp"

namespace imufusion {
namespace {

bool finite_pose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

std::string format(double value) {
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

// A translation direction is free when the left-out directions move along it: the
// eigenvectors of sum t t^T over their translation parts t (unit 6-vectors, so a pure
// translation gives 1, a pure rotation 0) with eigenvalue below one half are fixed.
Eigen::Matrix3d fixed_translation_without(
    const std::vector<Eigen::Matrix<double, 6, 1>>& left_out) {
  Eigen::Matrix3d free = Eigen::Matrix3d::Zero();
  for (const auto& u : left_out) free += u.tail<3>() * u.tail<3>().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(free);
  Eigen::Matrix3d fixed = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i)
    if (eig.eigenvalues()(i) < 0.5)
      fixed += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
  return fixed;
}

using Vector6d = Eigen::Matrix<double, 6, 1>;

// r = sum w (a.x - b)^2 = x^T AtA x - 2 x^T Atb + btb, exact for the reduced sums.
double residual_at(const NormalEquations& eq, const Vector6d& x) {
  return std::max(0.0, x.dot(eq.AtA * x) - 2 * x.dot(eq.Atb) + eq.btb);
}

// The ICP update x that moves T onto T_target (icp_increment(x) * T = T_target).
Vector6d update_towards(const Eigen::Isometry3d& T_target, const Eigen::Isometry3d& T) {
  const Eigen::Isometry3d delta = T_target * T.inverse();
  Vector6d x;
  x << log_so3(delta.linear()), delta.translation();
  return x;
}

// IcpConfig::seed_prior and seed_agreement_chi2: the initial pose's information per component
// of x (rad^-2, m^-2), or nothing unless both sigmas are given (a prior on some directions only
// would leave the others to the depth alone, degenerate or not).
std::optional<Vector6d> seed_information(const IcpConfig& config) {
  if (!(config.seed_prior || config.seed_agreement_chi2 > 0) || !(config.seed_sigma_rotation > 0) ||
      !(config.seed_sigma_translation > 0))
    return {};
  Vector6d info;
  info.head<3>().setConstant(1 / (config.seed_sigma_rotation * config.seed_sigma_rotation));
  info.tail<3>().setConstant(1 / (config.seed_sigma_translation * config.seed_sigma_translation));
  return info;
}

// The depth's information per unit of AtA, 1 / (c s^2) (IcpConfig::seed_prior); 0 when the
// frame shows no noise to weigh it by.
double depth_information_scale(const NormalEquations& eq, const IcpStep& depth_only,
                               const IcpConfig& config, int level) {
  const double a = config.depth_noise.a;
  const double s2 = std::max(eq.weight_sum > 0 ? depth_only.residual / eq.weight_sum : 0.0, a * a);
  const double c = std::max(1.0, config.correlated_pixels / std::pow(4.0, level));
  return s2 > 0 ? 1 / (c * s2) : 0;
}

// The depth-only step with the initial pose added as a measurement of information `info`,
// `to_seed` away: x and the residual at x change; the condition, the singular directions and
// the fixed translation stay the depth's own.
void add_seed_prior(IcpStep& step, const NormalEquations& eq, double scale, const Vector6d& info,
                    const Vector6d& to_seed) {
  Eigen::Matrix<double, 6, 6> H = eq.system_AtA() * scale;
  H.diagonal() += info;
  const Vector6d x = H.ldlt().solve(eq.system_Atb() * scale + info.cwiseProduct(to_seed));
  if (!x.allFinite()) return;
  step.x = x;
  step.residual = residual_at(eq, x);
}

// chi^2 of a Gauss-Newton step `x` under ICP's own covariance, (scale AtA)^-1; 0 without a scale.
double step_chi2(const NormalEquations& eq, double scale, const Vector6d& x) {
  return scale > 0 ? scale * x.dot(eq.system_AtA() * x) : 0.0;
}

// chi^2 of the move `moved` from the initial pose under the seed's covariance plus ICP's,
// (scale AtA)^-1; infinity when AtA is singular.
double seed_chi2(const NormalEquations& eq, double scale, const Vector6d& info,
                 const Vector6d& moved) {
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> depth((eq.system_AtA() * scale).eval());
  if (depth.info() != Eigen::Success || !(depth.vectorD().minCoeff() > 0))
    return std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, 6, 6> S = depth.solve(Eigen::Matrix<double, 6, 6>::Identity());
  S.diagonal() += info.cwiseInverse();
  const double chi2 = moved.dot(S.ldlt().solve(moved));
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}

// IcpConfig::seed_agreement_chi2: an unreliable, converged result whose only faults are the
// pairing and residual tests (each fraction at least half its threshold, r / sum(w) at most
// twice its) becomes reliable when its chi^2 from the initial pose is within the limit.
void accept_if_agreeing(const IcpConfig& config, IcpResult& result) {
  IcpQuality& q = result.quality;
  if (result.reliable() || !q.converged || !(config.seed_agreement_chi2 > 0) ||
      !(q.seed_chi2 <= config.seed_agreement_chi2))
    return;
  IcpReliabilityThresholds pairing = config.reliability;
  pairing.min_inlier_fraction *= 0.5;
  pairing.min_pixel_fraction *= 0.5;
  pairing.max_residual_per_weight *= 2;
  if (!judge_icp(q, pairing, nullptr)) return;
  result.verdict = IcpVerdict::kReliable;
  q.agreed_with_seed = true;
  result.reason.clear();
}

// The end of a partial result's reason.
std::string partial_reason(int constrained) {
  return "; " + std::to_string(constrained) +
         " of 6 directions from ICP, the rest from the initial pose";
}

// The seed gate (IcpConfig::seed_sigma_rotation): along the weakly constrained singular
// directions of the last step's AtA, ICP's motion from the initial pose must stay within the
// combined uncertainty of the initial pose and of ICP itself (r / sum(w) / sigma_i); the
// directions beyond it are moved back to the initial pose and the result becomes partial.
void gate_against_seed(const IcpStep& last, const IcpConfig& config,
                       const Eigen::Isometry3d& T_init, IcpResult& result) {
  const Eigen::Matrix<double, 6, 1>& s = last.singular_values;
  const Eigen::Matrix<double, 6, 6>& U = last.directions;
  const Vector6d xi = update_towards(result.T_ref_cur, T_init);
  const double sr2 = config.seed_sigma_rotation * config.seed_sigma_rotation;
  const double st2 = config.seed_sigma_translation * config.seed_sigma_translation;
  std::vector<Eigen::Matrix<double, 6, 1>> left_out;
  Eigen::Matrix<double, 6, 1> removed = Eigen::Matrix<double, 6, 1>::Zero();
  double worst = 0, worst_kappa = 0;
  for (int i = 0; i < 6; ++i) {
    const double kappa = s(i) > 0 ? s(0) / s(i) : std::numeric_limits<double>::infinity();
    const Eigen::Matrix<double, 6, 1> u = U.col(i);
    if (kappa > config.reliability.max_condition) {  // already kept at the seed, partial or not
      left_out.push_back(u);
      continue;
    }
    if (!(kappa > config.seed_gate_condition)) continue;
    const double var = u.head<3>().squaredNorm() * sr2 + u.tail<3>().squaredNorm() * st2 +
                       result.quality.residual_per_weight / s(i);
    const double move = u.dot(xi);
    const double sigmas = std::abs(move) / std::sqrt(var);
    if (sigmas > worst) {
      worst = sigmas;
      worst_kappa = kappa;
    }
    if (sigmas > config.seed_gate_sigmas) {
      left_out.push_back(u);
      removed += u * move;
      ++result.quality.seed_gated_directions;
    }
  }
  result.quality.seed_disagreement = worst;
  if (result.quality.seed_gated_directions == 0) return;
  const int constrained = 6 - static_cast<int>(left_out.size());
  const Eigen::Matrix<double, 6, 1> kept = xi - removed;
  result.T_ref_cur = icp_increment(kept) * T_init;
  result.quality.constrained_directions = constrained;
  const bool was_reliable = result.reliable();
  result.verdict = constrained >= config.min_constrained_directions ? IcpVerdict::kPartial
                                                                    : IcpVerdict::kUnreliable;
  result.fixed_translation =
      result.partial() ? fixed_translation_without(left_out) : Eigen::Matrix3d::Zero();
  std::string why = "moved " + format(worst) +
                    " sigma from the initial pose along a direction with kappa " +
                    format(worst_kappa);
  if (!was_reliable) why = result.reason + "; " + why;
  result.reason = why + (result.partial() ? partial_reason(constrained) : std::string());
}

}  // namespace

Status IcpConfig::validate(int levels) const {
  auto bad = [](const std::string& what) { return make_error(ErrorCode::kInvalidArgument, what); };
  const auto n = static_cast<std::size_t>(levels);
  if (iterations_per_level.size() < n || max_distance.size() < n ||
      max_normal_angle_deg.size() < n) {
    return bad("ICP needs iterations, max_distance and max_normal_angle_deg for each of the " +
               std::to_string(levels) + " pyramid levels");
  }
  if (max_total_iterations < 1 || max_total_iterations > 100)
    return bad("max_total_iterations must be 1..100, got " + std::to_string(max_total_iterations));
  if (max_unsettled_iterations < 0 || max_unsettled_iterations > 100)
    return bad("max_unsettled_iterations must be 0..100, got " +
               std::to_string(max_unsettled_iterations));
  if (!(settled_chi2 > 0) || !std::isfinite(settled_chi2))
    return bad("settled_chi2 must be positive and finite, got " + format(settled_chi2));
  for (std::size_t l = 0; l < n; ++l) {
    if (iterations_per_level[l] < 0) return bad("negative ICP iteration count");
    if (!(max_distance[l] > 0)) return bad("ICP max_distance must be positive");
    if (!(max_normal_angle_deg[l] > 0 && max_normal_angle_deg[l] < 90))
      return bad("ICP max_normal_angle_deg must be in (0, 90)");
  }
  if (iterations_per_level[0] < 1) return bad("ICP must run at least one iteration at level 0");
  if (!(depth_noise.a >= 0 && depth_noise.b >= 0 &&
        std::isfinite(depth_noise.a + depth_noise.b + depth_noise.z0)))
    return bad("depth noise coefficients must be finite and non-negative");
  for (const auto& [name, value] :
       {std::pair<const char*, double>{"min_inlier_fraction", reliability.min_inlier_fraction},
        {"min_pixel_fraction", reliability.min_pixel_fraction}}) {
    if (!(value >= 0 && value <= 1))
      return bad(std::string(name) + " must be in [0, 1], got " + format(value));
  }
  if (!(normal_gate.noise_k >= 0 && std::isfinite(normal_gate.noise_k)))
    return bad("normal_gate.noise_k must be finite and non-negative, got " +
               format(normal_gate.noise_k));
  if (!(normal_gate.max_angle_deg > 0 && normal_gate.max_angle_deg < 90))
    return bad("normal_gate.max_angle_deg must be in (0, 90), got " +
               format(normal_gate.max_angle_deg));
  if (min_constrained_directions < 1 || min_constrained_directions > 6)
    return bad("min_constrained_directions must be 1..6, got " +
               std::to_string(min_constrained_directions));
  if (!(seed_sigma_rotation >= 0 && std::isfinite(seed_sigma_rotation) &&
        seed_sigma_translation >= 0 && std::isfinite(seed_sigma_translation)))
    return bad("seed sigmas must be finite and non-negative");
  if (!(seed_gate_condition >= 1 && std::isfinite(seed_gate_condition)))
    return bad("seed_gate_condition must be at least 1, got " + format(seed_gate_condition));
  if (!(seed_gate_sigmas > 0 && std::isfinite(seed_gate_sigmas)))
    return bad("seed_gate_sigmas must be positive, got " + format(seed_gate_sigmas));
  if (!(correlated_pixels >= 1 && std::isfinite(correlated_pixels)))
    return bad("correlated_pixels must be at least 1, got " + format(correlated_pixels));
  if (!(seed_agreement_chi2 >= 0 && std::isfinite(seed_agreement_chi2)))
    return bad("seed_agreement_chi2 must be finite and non-negative, got " +
               format(seed_agreement_chi2));
  if (!(photometric.weight >= 0 && std::isfinite(photometric.weight)))
    return bad("photometric.weight must be finite and non-negative, got " +
               format(photometric.weight));
  if (!(photometric.huber_sigmas > 0 && std::isfinite(photometric.huber_sigmas)))
    return bad("photometric.huber_sigmas must be positive, got " +
               format(photometric.huber_sigmas));
  if (!(photometric.initial_huber > 0 && std::isfinite(photometric.initial_huber)))
    return bad("photometric.initial_huber must be positive, got " +
               format(photometric.initial_huber));
  if (!(photometric.min_sigma >= 0 && std::isfinite(photometric.min_sigma)))
    return bad("photometric.min_sigma must be finite and non-negative, got " +
               format(photometric.min_sigma));
  if (photometric.pixel_step < 1 || photometric.pixel_step > 16)
    return bad("photometric.pixel_step must be 1..16, got " +
               std::to_string(photometric.pixel_step));
  if (!(seed_gate_hold_sigmas > 0 && seed_gate_hold_sigmas <= seed_gate_sigmas))
    return bad("seed_gate_hold_sigmas must be in (0, seed_gate_sigmas], got " +
               format(seed_gate_hold_sigmas));
  if (!(partial_min_fraction >= 0 && partial_min_fraction <= 1))
    return bad("partial_min_fraction must be in [0, 1], got " + format(partial_min_fraction));
  return {};
}

void add_photometric(NormalEquations& eq, const NormalEquations& photo, double weight,
                     double min_depth_variance, double min_photometric_variance) {
  if (!(weight > 0) || !(eq.weight_sum > 0) || !(photo.btb > 0) || !(photo.weight_sum > 0)) return;
  const double depth_variance = std::max(eq.btb / eq.weight_sum, min_depth_variance);
  if (!(depth_variance > 0)) return;
  const double photometric_variance =
      std::max(photo.btb / photo.weight_sum, min_photometric_variance);
  const double lambda = weight * depth_variance / photometric_variance;
  eq.photometric_AtA += lambda * photo.AtA;
  eq.photometric_Atb += lambda * photo.Atb;
  eq.photometric_pairs += photo.inliers;
}

IcpStep solve_icp_step(const NormalEquations& eq, double max_condition) {
  IcpStep step;
  const Eigen::Matrix<double, 6, 6> AtA = eq.system_AtA();
  const Eigen::Matrix<double, 6, 1> Atb = eq.system_Atb();
  if (eq.inliers < 6 || !AtA.allFinite() || !Atb.allFinite() || !std::isfinite(eq.btb)) {
    step.condition = std::numeric_limits<double>::infinity();
    return step;
  }
  // The directions, their singular values and kappa are the depth's own: a colour term neither
  // makes a bare wall's alignment reliable nor moves the pose along a direction the depth leaves
  // unconstrained (it refines those the depth fixes).
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> svd(
      eq.AtA, Eigen::ComputeFullU | Eigen::ComputeFullV);
  step.directions = svd.matrixU();
  // Element by element: GCC 12 reports the vectorized whole-vector copy as maybe-uninitialized.
  for (int i = 0; i < 6; ++i) step.singular_values(i) = svd.singularValues()(i);
  const Eigen::Matrix<double, 6, 1>& s = step.singular_values;  // descending
  step.condition = s(5) > 0 ? s(0) / s(5) : std::numeric_limits<double>::infinity();
  if (!(s(0) > 0)) return step;
  const Eigen::Matrix<double, 6, 6>& U = svd.matrixU();
  const bool photometric = eq.photometric_pairs > 0;
  if (max_condition > 0) {
    for (int i = 0; i < 6; ++i) {
      if (!(s(i) > 0) || s(0) / s(i) > max_condition) break;
      ++step.constrained_directions;
    }
    const int k = step.constrained_directions;
    if (!photometric) {
      // Truncated SVD: AtA is symmetric, so its SVD is U S U^T and x = sum over kept i of
      // u_i (u_i . Atb) / s_i.
      for (int i = 0; i < k; ++i) step.x += U.col(i) * (U.col(i).dot(Atb) / s(i));
    } else if (k > 0) {
      // The whole system solved within the span of the depth's kept directions.
      const Eigen::MatrixXd Uk = U.leftCols(k);
      const Eigen::MatrixXd H = Uk.transpose() * AtA * Uk;
      step.x = Uk * H.ldlt().solve(Uk.transpose() * Atb);
    }
    std::vector<Eigen::Matrix<double, 6, 1>> left_out;
    for (int i = step.constrained_directions; i < 6; ++i) left_out.push_back(U.col(i));
    step.fixed_translation = fixed_translation_without(left_out);
  } else {
    if (photometric) {
      const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> whole(
          AtA, Eigen::ComputeFullU | Eigen::ComputeFullV);
      step.x = whole.solve(Atb);
    } else {
      step.x = svd.solve(Atb);
    }
    step.constrained_directions = 6;
    step.fixed_translation.setIdentity();
  }
  if (!step.x.allFinite()) {
    step.x.setZero();
    return step;
  }
  step.residual = residual_at(eq, step.x);
  step.solvable = true;
  return step;
}

Eigen::Isometry3d icp_increment(const Eigen::Matrix<double, 6, 1>& x) {
  Eigen::Isometry3d inc = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d omega = x.head<3>();
  const double angle = omega.norm();
  if (angle > 0) inc.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  inc.translation() = x.tail<3>();
  return inc;
}

double DepthNoiseModel::mean_variance(const DepthView& depth, double min_depth,
                                      double max_depth) const {
  double sum = 0;
  std::size_t n = 0;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const double z = depth.metres(u, v);
      if (z == 0 || z < min_depth || z > max_depth) continue;
      const double s = sigma(z);
      sum += s * s;
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

IcpReliabilityThresholds IcpReliabilityThresholds::widened_to_noise(double noise_variance) const {
  IcpReliabilityThresholds t = *this;
  t.max_residual_per_weight = std::max(t.max_residual_per_weight, 2.0 * noise_variance);
  return t;
}

bool judge_icp(const IcpQuality& q, const IcpReliabilityThresholds& t, std::string* reason) {
  std::string why;
  if (q.inliers == 0) {
    why = "no correspondences";
  } else if (q.inliers < t.min_inliers) {
    why = "inliers " + std::to_string(q.inliers) + " < " + std::to_string(t.min_inliers);
  } else if (q.inlier_fraction < t.min_inlier_fraction) {
    why = "inlier fraction " + format(q.inlier_fraction) + " < " + format(t.min_inlier_fraction);
  } else if (q.pixel_fraction < t.min_pixel_fraction) {
    why = "pixel fraction " + format(q.pixel_fraction) + " < " + format(t.min_pixel_fraction);
  } else if (!(q.condition <= t.max_condition)) {
    why = "condition " + format(q.condition) + " > " + format(t.max_condition);
  } else if (!(q.residual_per_weight <= t.max_residual_per_weight)) {
    why = "residual/weight " + format(q.residual_per_weight) + " > " +
          format(t.max_residual_per_weight);
  }
  if (reason != nullptr) *reason = why;
  return why.empty();
}

namespace {

// What the verdict on an alignment needs from its last steps.
struct LastStep {
  IcpStep step;        // the last step (kept for the seed gate)
  NormalEquations eq;  // level 0's last system, for the agreement with the seed
  double scale = 0;    // its information scale (depth_information_scale)
  Eigen::Matrix3d fixed = Eigen::Matrix3d::Zero();  // the last step's fixed translation directions
  int finest_run = 0;                               // the finest level that ran a step
  /// The last step's AtA, any level (NaN until a step ran): its translation condition.
  Eigen::Matrix<double, 6, 6> AtA =
      Eigen::Matrix<double, 6, 6>::Constant(std::numeric_limits<double>::quiet_NaN());
};

// kappa of the translation block of the depth's AtA (inf when singular or not finite).
double translation_condition(const Eigen::Matrix<double, 6, 6>& AtA) {
  const Eigen::Matrix3d block = AtA.bottomRightCorner<3, 3>();
  if (!block.allFinite()) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(block, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d& values = solver.eigenvalues();  // ascending
  return values(0) > 0 ? values(2) / values(0) : std::numeric_limits<double>::infinity();
}

// The quality figures of one Gauss-Newton step.
void record_step(IcpQuality& q, const NormalEquations& eq, const IcpStep& step) {
  q.inliers = eq.inliers;
  q.weight_sum = eq.weight_sum;
  q.inlier_fraction = eq.inlier_fraction();
  q.covered_fraction = eq.covered_fraction();
  q.covered_inlier_fraction = eq.covered_inlier_fraction();
  q.pixel_fraction = eq.pixel_fraction();
  q.condition = step.condition;
  q.residual = step.residual;
  q.residual_per_inlier = eq.inliers > 0 ? step.residual / double(eq.inliers) : 0;
  q.residual_per_weight = eq.weight_sum > 0 ? step.residual / eq.weight_sum : 0;
  q.constrained_directions = step.constrained_directions;
}

// The verdict on a finished alignment: the reliability test at level 0, the agreement with the
// seed, a partial solve where only the condition fails, then the seed gate.
void judge_result(IcpResult& result, const IcpConfig& config, const LastStep& last,
                  const std::optional<Vector6d>& prior, bool seed_gate,
                  const Eigen::Isometry3d& T_ref_cur_init) {
  result.verdict = judge_icp(result.quality, config.reliability, &result.reason)
                       ? IcpVerdict::kReliable
                       : IcpVerdict::kUnreliable;
  if (result.reliable() && last.finest_run != 0) {
    result.verdict = IcpVerdict::kUnreliable;
    result.reason = "level 0 was not reached";
  }
  if (prior && last.finest_run == 0 && last.scale > 0) {
    result.quality.seed_chi2 =
        seed_chi2(last.eq, last.scale, *prior, update_towards(result.T_ref_cur, T_ref_cur_init));
    if (result.quality.condition <= config.reliability.max_condition)
      accept_if_agreeing(config, result);
  }
  if (!result.reliable() && config.keep_seed_in_degenerate_directions && last.finest_run == 0 &&
      result.quality.constrained_directions >= config.min_constrained_directions) {
    // Partial: every test but the condition passes (judged with the condition let through, and
    // the pairing down to partial_min_fraction).
    IcpReliabilityThresholds t = config.reliability;
    t.max_condition = std::numeric_limits<double>::infinity();
    if (config.partial_min_fraction > 0) {
      t.min_inlier_fraction = std::min(t.min_inlier_fraction, config.partial_min_fraction);
      t.min_pixel_fraction = std::min(t.min_pixel_fraction, config.partial_min_fraction);
    }
    if (judge_icp(result.quality, t, nullptr)) {
      result.verdict = IcpVerdict::kPartial;
      result.fixed_translation = last.fixed;
      result.reason += partial_reason(result.quality.constrained_directions);
    }
  }
  if ((result.reliable() || result.partial()) && seed_gate)
    gate_against_seed(last.step, config, T_ref_cur_init, result);
}

}  // namespace

bool fixes_position(const IcpQuality& quality, IcpReliabilityThresholds thresholds,
                    double max_translation_condition) {
  if (!(max_translation_condition > 0) || quality.iterations == 0) return false;
  thresholds.max_condition = std::numeric_limits<double>::infinity();
  return quality.translation_condition <= max_translation_condition &&
         judge_icp(quality, thresholds, nullptr);
}

Result<IcpResult> run_icp(NormalEquationSource& source, const IcpConfig& config,
                          const Eigen::Isometry3d& T_ref_cur_init) {
  const int levels = source.levels();
  IMUFUSION_RETURN_IF_ERROR(config.validate(levels));
  IcpResult result;
  if (!finite_pose(T_ref_cur_init)) {
    result.reason = "initial pose is not finite";
    return result;
  }
  Eigen::Isometry3d T = T_ref_cur_init;
  int total = 0;
  int coarse = 0;
  bool any_step = false;
  LastStep last;
  last.finest_run = levels;
  // The seed gate judges the last step's singular directions: kept only when it may run.
  const bool seed_gate = config.seed_gate && config.keep_seed_in_degenerate_directions &&
                         (config.seed_sigma_rotation > 0 || config.seed_sigma_translation > 0);
  const std::optional<Vector6d> prior = seed_information(config);
  for (int level = levels - 1; level >= 0; --level) {
    // Keep one iteration for every finer level, so a small budget is spent at full resolution.
    const int budget = config.max_total_iterations - total - level;
    const int allowed = config.iterations_per_level[static_cast<std::size_t>(level)];
    const int iterations = std::min(allowed, budget);
    // Level 0 may step on past the budget while its steps still move the pose (settled_chi2).
    const int unsettled =
        level == 0 ? std::min(allowed, config.max_unsettled_iterations - total) : 0;
    if (std::max(iterations, unsettled) <= 0) continue;
    const auto l = static_cast<std::size_t>(level);
    const float min_cos =
        static_cast<float>(std::cos(config.max_normal_angle_deg[l] * M_PI / 180.0));
    bool converged = false;
    for (int it = 0; it < std::max(iterations, unsettled); ++it) {
      auto eq = source.evaluate(level, T, config.max_distance[l], min_cos);
      if (!eq) return eq.error();
      IcpStep step = solve_icp_step(
          *eq, config.keep_seed_in_degenerate_directions ? config.reliability.max_condition : 0.0);
      const double scale = step.solvable ? depth_information_scale(*eq, step, config, level) : 0.0;
      if (prior && step.solvable) {
        if (scale > 0 && config.seed_prior)
          add_seed_prior(step, *eq, scale, *prior, update_towards(T_ref_cur_init, T));
        if (level == 0) {
          last.eq = *eq;
          last.scale = scale;
        }
      }
      record_step(result.quality, *eq, step);
      last.AtA = eq->AtA;
      last.fixed = step.fixed_translation;
      if (seed_gate) last.step = step;
      ++total;
      if (level > 0) ++coarse;
      last.finest_run = level;
      if (!step.solvable) {
        converged = false;
        break;
      }
      any_step = true;
      const Eigen::Isometry3d next = icp_increment(step.x) * T;
      if (!finite_pose(next)) break;
      T = next;
      T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
      if (step.x.head<3>().norm() < config.converged_rotation &&
          step.x.tail<3>().norm() < config.converged_translation) {
        converged = true;
        break;
      }
      // The budget spent: on only while the step was larger than the frame's noise.
      if (it + 1 >= iterations && !(step_chi2(*eq, scale, step.x) > config.settled_chi2)) break;
    }
    result.quality.converged = converged;
  }
  result.quality.iterations = total;
  result.quality.coarse_iterations = coarse;
  result.T_ref_cur = T;
  result.quality.translation_condition = translation_condition(last.AtA);
  if (!any_step) {
    result.quality.converged = false;
    result.reason =
        result.quality.inliers == 0 ? "no correspondences" : "the ICP system is degenerate";
    return result;
  }
  judge_result(result, config, last, prior, seed_gate, T_ref_cur_init);
  return result;
}

}  // namespace imufusion
