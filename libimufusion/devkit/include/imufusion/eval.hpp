#pragma once
// Trajectory evaluation with the TUM RGB-D benchmark's definitions (Sturm et al., IROS 2012, and
// its scripts associate.py, evaluate_ate.py, evaluate_rpe.py): absolute trajectory error after a
// rigid alignment (no scale) and relative pose error over a fixed frame or time delta.
// Units: metres, seconds, degrees. Poses are T_world_camera (camera -> world), as in TUM files.

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// How poses of the ground truth and the estimate are paired by timestamp.
struct AssociationOptions {
  /// A pair is a candidate when |t_gt - (t_est + time_offset_s)| < max_difference_s (seconds,
  /// strict, as associate.py).
  double max_difference_s = 0.02;
  /// Added to every estimate timestamp before matching (seconds).
  double time_offset_s = 0.0;
};

/// One associated pair: indices into the ground-truth and estimate trajectories.
struct PoseMatch {
  std::size_t gt_index = 0;
  std::size_t est_index = 0;

  friend bool operator==(const PoseMatch&, const PoseMatch&) = default;
};

/// Pairs poses as associate.py does: every (gt, est) pair closer than max_difference_s is a
/// candidate; candidates are taken greedily in order of increasing |dt| (ties by gt then est
/// time), skipping any whose gt or estimate pose is already used, so each pose is used at most
/// once. The result is sorted by ground-truth time. Inputs need not be sorted.
/// Fails on non-finite timestamps or options; empty inputs give an empty result.
Result<std::vector<PoseMatch>> associate(const Trajectory& gt, const Trajectory& est,
                                         const AssociationOptions& options = {});

/// Summary of a set of non-negative errors. With count == 0 every other field is NaN.
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;  // std: population (ddof 0)
};

/// Statistics as numpy computes them in the TUM scripts (median of an even count averages the
/// two middle values).
ErrorStats compute_error_stats(const std::vector<double>& values);

/// Absolute trajectory error.
struct AteResult {
  std::vector<PoseMatch> matches;  // sorted by ground-truth time
  /// The rigid transform (no scale) that best maps estimate positions onto ground-truth
  /// positions in the least-squares sense: p_gt ~ T_gt_est * p_est (metres).
  Eigen::Isometry3d T_gt_est = Eigen::Isometry3d::Identity();
  std::vector<double> errors_m;  // ||T_gt_est * p_est - p_gt|| per match, metres
  ErrorStats stats;              // over errors_m, metres
};

/// Associates, aligns (Horn / Umeyama via Eigen::umeyama, no scale) and measures. Fails with a
/// message giving both trajectories' sizes and time spans when fewer than 3 poses match.
Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est,
                               const AssociationOptions& options = {});

/// The same for an association computed already (e.g. by `associate`).
Result<AteResult> evaluate_ate(const Trajectory& gt, const Trajectory& est,
                               const std::vector<PoseMatch>& matches);

enum class DeltaUnit {
  kFrames,   // delta counts matched poses: pair (k, k + delta)
  kSeconds,  // pair k with the matched pose whose estimate time is nearest t_k + delta
};

/// The step over which relative motion is compared.
struct RpeOptions {
  double delta = 1.0;  // frames (a positive integer) or seconds (> 0)
  DeltaUnit unit = DeltaUnit::kFrames;
  /// With kSeconds, k is skipped when no matched pose lies within this many seconds of
  /// t_k + delta.
  double time_tolerance_s = 0.02;
};

/// Relative pose error E_k = (Q_k^-1 Q_j)^-1 (P_k^-1 P_j), Q ground truth, P estimate, over the
/// pairs (k, j) the delta selects among the matched poses.
struct RpeResult {
  RpeOptions options;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;  // indices into the matches
  std::vector<double> trans_errors_m;                      // ||translation(E)||, metres
  std::vector<double> rot_errors_deg;                      // angle of rotation(E), degrees
  ErrorStats trans_m;
  ErrorStats rot_deg;
};

/// Relative pose error over `matches` (sorted by time, as `associate` returns them). A delta that
/// selects no pair (e.g. 1 s on a half-second trajectory) gives an empty result, not an error;
/// fewer than 2 matches or an invalid delta is an error.
Result<RpeResult> evaluate_rpe(const Trajectory& gt, const Trajectory& est,
                               const std::vector<PoseMatch>& matches, const RpeOptions& options);

/// Everything `evaluate` computes: ATE plus RPE per frame and per second by default.
struct EvalOptions {
  AssociationOptions association;
  RpeOptions rpe_frame{1.0, DeltaUnit::kFrames, 0.02};
  RpeOptions rpe_second{1.0, DeltaUnit::kSeconds, 0.02};
};

/// First and last timestamp of a trajectory (seconds).
struct TimeSpan {
  double begin = 0, end = 0;
};

struct TrajectoryMetrics {
  std::size_t gt_poses = 0, est_poses = 0;
  TimeSpan gt_span, est_span;
  AssociationOptions association;
  AteResult ate;  // ate.matches.size() poses were matched
  RpeResult rpe_frame;
  RpeResult rpe_second;
};

/// ATE and both RPEs. Fails on an empty trajectory or fewer than 3 matched poses.
Result<TrajectoryMetrics> evaluate(const Trajectory& gt, const Trajectory& est,
                                   const EvalOptions& options = {});

/// One JSON object (keys: matched, gt_poses, est_poses, ate_rmse, ate_mean, ate_median, ate_std,
/// ate_min, ate_max in metres, rpe_frame_* and rpe_second_* trans in metres and rot in degrees,
/// the deltas, and the alignment). Statistics with no samples are null.
std::string to_json(const TrajectoryMetrics& metrics);

}  // namespace imufusion
