#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

Status check_rpe_input(const Trajectory& gt, const Trajectory& est,
                       const std::vector<PoseMatch>& matches, const RpeOptions& options) {
  if (!std::isfinite(options.delta) || options.delta <= 0.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "RPE delta must be positive, got " + std::to_string(options.delta));
  }
  if (options.unit == DeltaUnit::kFrames && options.delta != std::floor(options.delta)) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "RPE delta in frames must be a whole number, got " + std::to_string(options.delta));
  }
  if (options.unit == DeltaUnit::kSeconds &&
      (!std::isfinite(options.time_tolerance_s) || options.time_tolerance_s < 0.0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "RPE time tolerance must be a non-negative number of seconds, got " +
                          std::to_string(options.time_tolerance_s));
  }
  if (matches.size() < 2) {
    return make_error(ErrorCode::kInvalidArgument,
                      "RPE needs at least 2 matched poses, got " + std::to_string(matches.size()));
  }
  for (std::size_t k = 0; k < matches.size(); ++k) {
    if (matches[k].gt_index >= gt.size() || matches[k].est_index >= est.size()) {
      return make_error(ErrorCode::kInvalidArgument,
                        "match " + std::to_string(k) + " refers to a pose outside the " +
                            "trajectories (" + std::to_string(gt.size()) + " ground-truth, " +
                            std::to_string(est.size()) + " estimate poses)");
    }
  }
  return {};
}

std::vector<std::pair<std::size_t, std::size_t>> frame_pairs(std::size_t count, std::size_t delta) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k + delta < count; ++k) pairs.emplace_back(k, k + delta);
  return pairs;
}

// For each match k, the match j whose estimate time is nearest t_k + delta (evaluate_rpe.py's
// time-based delta); k is skipped when that nearest time is further than the tolerance away.
std::vector<std::pair<std::size_t, std::size_t>> time_pairs(const Trajectory& est,
                                                            const std::vector<PoseMatch>& matches,
                                                            double delta_s, double tolerance_s) {
  std::vector<std::pair<double, std::size_t>> by_time;  // (estimate time, match index)
  by_time.reserve(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) {
    by_time.emplace_back(est[matches[k].est_index].timestamp, k);
  }
  std::sort(by_time.begin(), by_time.end());

  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const double target = est[matches[k].est_index].timestamp + delta_s;
    auto after =
        std::lower_bound(by_time.begin(), by_time.end(), std::make_pair(target, std::size_t{0}));
    auto nearest = after;
    if (after == by_time.end() ||
        (after != by_time.begin() && target - std::prev(after)->first < after->first - target)) {
      nearest = std::prev(after);
    }
    if (std::abs(nearest->first - target) > tolerance_s || nearest->second == k) continue;
    pairs.emplace_back(k, nearest->second);
  }
  return pairs;
}

}  // namespace

Result<RpeResult> evaluate_rpe(const Trajectory& gt, const Trajectory& est,
                               const std::vector<PoseMatch>& matches, const RpeOptions& options) {
  IMUFUSION_RETURN_IF_ERROR(check_rpe_input(gt, est, matches, options));

  RpeResult result;
  result.options = options;
  result.pairs = options.unit == DeltaUnit::kFrames
                     ? frame_pairs(matches.size(), static_cast<std::size_t>(options.delta))
                     : time_pairs(est, matches, options.delta, options.time_tolerance_s);

  result.trans_errors_m.reserve(result.pairs.size());
  result.rot_errors_deg.reserve(result.pairs.size());
  for (const auto& [k, j] : result.pairs) {
    const Eigen::Isometry3d& q_k = gt[matches[k].gt_index].T_world_camera;
    const Eigen::Isometry3d& q_j = gt[matches[j].gt_index].T_world_camera;
    const Eigen::Isometry3d& p_k = est[matches[k].est_index].T_world_camera;
    const Eigen::Isometry3d& p_j = est[matches[j].est_index].T_world_camera;
    // E = (Q_k^-1 Q_j)^-1 (P_k^-1 P_j) (Sturm et al. 2012, eq. 1): identity when the estimate's
    // motion from k to j equals the ground truth's, whatever frame either world is in.
    const Eigen::Isometry3d error = (q_k.inverse() * q_j).inverse() * (p_k.inverse() * p_j);
    result.trans_errors_m.push_back(error.translation().norm());
    // The quaternion form (2 atan2(|v|, |w|)) keeps precision for small angles, where
    // acos((trace - 1) / 2) loses it.
    const double angle_rad = Eigen::AngleAxisd(Eigen::Quaterniond(error.linear())).angle();
    result.rot_errors_deg.push_back(angle_rad * 180.0 / std::numbers::pi);
  }
  result.trans_m = compute_error_stats(result.trans_errors_m);
  result.rot_deg = compute_error_stats(result.rot_errors_deg);
  return result;
}

}  // namespace imufusion
