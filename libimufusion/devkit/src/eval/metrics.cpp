#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <string>

#include "eval/eval_internal.hpp"
#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

// Writes prefix_rmse ... prefix_max (plus the unit suffix); nlohmann writes NaN (no samples) as
// null, which is what a reader of an empty statistic should see.
void put_stats(nlohmann::json& object, const std::string& prefix, const ErrorStats& stats,
               const std::string& suffix) {
  object[prefix + "_rmse" + suffix] = stats.rmse;
  object[prefix + "_mean" + suffix] = stats.mean;
  object[prefix + "_median" + suffix] = stats.median;
  object[prefix + "_std" + suffix] = stats.std;
  object[prefix + "_min" + suffix] = stats.min;
  object[prefix + "_max" + suffix] = stats.max;
}

void put_rpe(nlohmann::json& object, const std::string& prefix, const RpeResult& rpe) {
  object[prefix + "_delta"] = rpe.options.delta;
  object[prefix + "_delta_unit"] = rpe.options.unit == DeltaUnit::kFrames ? "frames" : "s";
  object[prefix + "_pairs"] = rpe.pairs.size();
  put_stats(object, prefix + "_trans", rpe.trans_m, "");
  put_stats(object, prefix + "_rot", rpe.rot_deg, "_deg");
}

}  // namespace

Result<TrajectoryMetrics> evaluate(const Trajectory& gt, const Trajectory& est,
                                   const EvalOptions& options) {
  Result<AteResult> ate = evaluate_ate(gt, est, options.association);
  if (!ate.ok()) return ate.error();

  TrajectoryMetrics metrics;
  metrics.gt_poses = gt.size();
  metrics.est_poses = est.size();
  metrics.gt_span = eval_internal::time_span(gt);
  metrics.est_span = eval_internal::time_span(est);
  metrics.association = options.association;
  metrics.ate = std::move(ate).value();

  Result<RpeResult> rpe_frame = evaluate_rpe(gt, est, metrics.ate.matches, options.rpe_frame);
  if (!rpe_frame.ok()) return rpe_frame.error();
  metrics.rpe_frame = std::move(rpe_frame).value();
  Result<RpeResult> rpe_second = evaluate_rpe(gt, est, metrics.ate.matches, options.rpe_second);
  if (!rpe_second.ok()) return rpe_second.error();
  metrics.rpe_second = std::move(rpe_second).value();
  return metrics;
}

std::string to_json(const TrajectoryMetrics& metrics) {
  nlohmann::json object;
  object["gt_poses"] = metrics.gt_poses;
  object["est_poses"] = metrics.est_poses;
  object["matched"] = metrics.ate.matches.size();
  object["gt_span_s"] = {metrics.gt_span.begin, metrics.gt_span.end};
  object["est_span_s"] = {metrics.est_span.begin, metrics.est_span.end};
  object["max_difference_s"] = metrics.association.max_difference_s;
  object["time_offset_s"] = metrics.association.time_offset_s;
  put_stats(object, "ate", metrics.ate.stats, "");
  put_rpe(object, "rpe_frame", metrics.rpe_frame);
  put_rpe(object, "rpe_second", metrics.rpe_second);

  const Eigen::Vector3d t = metrics.ate.T_gt_est.translation();
  const Eigen::Quaterniond q(metrics.ate.T_gt_est.linear());
  // TUM order: tx ty tz qx qy qz qw; maps estimate-world points into ground-truth world.
  object["alignment_T_gt_est"] = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
  return object.dump();
}

}  // namespace imufusion
