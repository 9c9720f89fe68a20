#include <Eigen/Geometry>
#include <cstdio>
#include <string>
#include <vector>

#include "eval/eval_internal.hpp"
#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

// Rigid alignment needs three non-collinear points to be determined; the TUM scripts and this
// function refuse fewer than three matches outright.
constexpr std::size_t kMinAteMatches = 3;

Status check_matches(const Trajectory& gt, const Trajectory& est,
                     const std::vector<PoseMatch>& matches) {
  for (std::size_t k = 0; k < matches.size(); ++k) {
    if (matches[k].gt_index >= gt.size() || matches[k].est_index >= est.size()) {
      return make_error(
          ErrorCode::kInvalidArgument,
          "match " + std::to_string(k) + " refers to pose (" + std::to_string(matches[k].gt_index) +
              ", " + std::to_string(matches[k].est_index) + ") outside the trajectories (" +
              std::to_string(gt.size()) + ", " + std::to_string(est.size()) + " poses)");
    }
  }
  return {};
}

Status check_not_empty(const Trajectory& gt, const Trajectory& est) {
  if (gt.empty())
    return make_error(ErrorCode::kInvalidArgument, "ground-truth trajectory is empty");
  if (est.empty()) return make_error(ErrorCode::kInvalidArgument, "estimate trajectory is empty");
  return {};
}

std::string too_few_matches(std::size_t matched, const Trajectory& gt, const Trajectory& est,
                            const std::string& within) {
  return "only " + std::to_string(matched) + " poses matched" + within + " (ATE needs at least " +
         std::to_string(kMinAteMatches) + "): " + eval_internal::describe_mismatch(gt, est);
}

Result<AteResult> align_and_measure(const Trajectory& gt, const Trajectory& est,
                                    const std::vector<PoseMatch>& matches) {
  const auto n = static_cast<Eigen::Index>(matches.size());
  Eigen::Matrix3Xd est_positions(3, n);
  Eigen::Matrix3Xd gt_positions(3, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const PoseMatch& m = matches[static_cast<std::size_t>(k)];
    est_positions.col(k) = est[m.est_index].T_world_camera.translation();
    gt_positions.col(k) = gt[m.gt_index].T_world_camera.translation();
  }
  if (!est_positions.allFinite() || !gt_positions.allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, "a matched pose has a non-finite position");
  }

  AteResult result;
  result.matches = matches;
  // evaluate_ate.py aligns the estimate onto the ground truth (its align(second, first)); no
  // scale, because a metric depth camera's trajectory must not be forgiven a scale error.
  result.T_gt_est.matrix() = Eigen::umeyama(est_positions, gt_positions, false);
  const Eigen::Matrix3Xd residuals = (result.T_gt_est * est_positions) - gt_positions;
  result.errors_m.resize(matches.size());
  for (Eigen::Index k = 0; k < n; ++k) {
    result.errors_m[static_cast<std::size_t>(k)] = residuals.col(k).norm();
  }
  result.stats = compute_error_stats(result.errors_m);
  return result;
}

}  // namespace

Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est,
                               const AssociationOptions& options) {
  IMUFUSION_RETURN_IF_ERROR(check_not_empty(gt, est));
  Result<std::vector<PoseMatch>> matches = associate(gt, est, options);
  if (!matches.ok()) return matches.error();
  if (matches->size() < kMinAteMatches) {
    char within[64];
    std::snprintf(within, sizeof(within), " within %g s", options.max_difference_s);
    std::string message = too_few_matches(matches->size(), gt, est, within);
    if (options.time_offset_s != 0.0) {
      char offset[96];
      std::snprintf(offset, sizeof(offset),
                    " (spans as in the files; estimate times were shifted by %+g s for matching)",
                    options.time_offset_s);
      message += offset;
    }
    return make_error(ErrorCode::kInvalidArgument, message);
  }
  return align_and_measure(gt, est, *matches);
}

Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est,
                               const std::vector<PoseMatch>& matches) {
  IMUFUSION_RETURN_IF_ERROR(check_not_empty(gt, est));
  IMUFUSION_RETURN_IF_ERROR(check_matches(gt, est, matches));
  if (matches.size() < kMinAteMatches) {
    return make_error(ErrorCode::kInvalidArgument, too_few_matches(matches.size(), gt, est, ""));
  }
  return align_and_measure(gt, est, matches);
}

}  // namespace imufusion
