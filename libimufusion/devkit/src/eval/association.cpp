#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <tuple>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

Status check_timestamps(const Trajectory& trajectory, const char* name) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!std::isfinite(trajectory[i].timestamp)) {
      return make_error(
          ErrorCode::kInvalidArgument,
          std::string(name) + " pose " + std::to_string(i) + " has a non-finite timestamp");
    }
  }
  return {};
}

// Indices of `trajectory` ordered by timestamp (stable, so equal stamps keep file order).
std::vector<std::size_t> time_order(const Trajectory& trajectory) {
  std::vector<std::size_t> order(trajectory.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return trajectory[a].timestamp < trajectory[b].timestamp;
  });
  return order;
}

struct Candidate {
  double abs_dt;  // seconds
  double t_gt;
  double t_est;  // without the offset, as associate.py sorts (diff, a, b)
  std::size_t gt_index;
  std::size_t est_index;

  bool operator<(const Candidate& other) const {
    return std::tie(abs_dt, t_gt, t_est, gt_index, est_index) <
           std::tie(other.abs_dt, other.t_gt, other.t_est, other.gt_index, other.est_index);
  }
};

}  // namespace

Result<std::vector<PoseMatch>> associate(const Trajectory& gt, const Trajectory& est,
                                         const AssociationOptions& options) {
  if (!std::isfinite(options.max_difference_s) || options.max_difference_s <= 0.0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "association max difference must be a positive number of seconds, got " +
                          std::to_string(options.max_difference_s));
  }
  if (!std::isfinite(options.time_offset_s)) {
    return make_error(ErrorCode::kInvalidArgument, "association time offset is not finite");
  }
  IMUFUSION_RETURN_IF_ERROR(check_timestamps(gt, "ground-truth"));
  IMUFUSION_RETURN_IF_ERROR(check_timestamps(est, "estimate"));

  const std::vector<std::size_t> est_order = time_order(est);
  std::vector<double> est_times(est_order.size());  // shifted by the offset, ascending
  for (std::size_t k = 0; k < est_order.size(); ++k) {
    est_times[k] = est[est_order[k]].timestamp + options.time_offset_s;
  }

  // Only pairs inside the window can be candidates, so a binary search per ground-truth pose
  // finds the same candidate set as associate.py's all-pairs loop without its O(N M) cost.
  std::vector<Candidate> candidates;
  for (std::size_t g = 0; g < gt.size(); ++g) {
    const double t = gt[g].timestamp;
    auto it = std::lower_bound(est_times.begin(), est_times.end(), t - options.max_difference_s);
    for (; it != est_times.end() && *it <= t + options.max_difference_s; ++it) {
      const double abs_dt = std::abs(t - *it);
      if (abs_dt >= options.max_difference_s) continue;
      const std::size_t e = est_order[static_cast<std::size_t>(it - est_times.begin())];
      candidates.push_back({abs_dt, t, est[e].timestamp, g, e});
    }
  }
  std::sort(candidates.begin(), candidates.end());

  std::vector<bool> gt_used(gt.size(), false);
  std::vector<bool> est_used(est.size(), false);
  std::vector<PoseMatch> matches;
  for (const Candidate& c : candidates) {
    if (gt_used[c.gt_index] || est_used[c.est_index]) continue;
    gt_used[c.gt_index] = true;
    est_used[c.est_index] = true;
    matches.push_back({c.gt_index, c.est_index});
  }
  std::sort(matches.begin(), matches.end(), [&](const PoseMatch& a, const PoseMatch& b) {
    return std::tie(gt[a.gt_index].timestamp, a.gt_index) <
           std::tie(gt[b.gt_index].timestamp, b.gt_index);
  });
  return matches;
}

}  // namespace imufusion
