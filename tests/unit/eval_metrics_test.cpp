#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

Eigen::Isometry3d make_pose(const Eigen::Vector3d& position, const Eigen::AngleAxisd& rotation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.toRotationMatrix();
  pose.translation() = position;
  return pose;
}

// 100 Hz ground truth over `seconds`, like a motion-capture recording.
Trajectory mocap_trajectory(double seconds) {
  Trajectory trajectory;
  for (int k = 0; k * 0.01 <= seconds; ++k) {
    const double t = k * 0.01;
    const Eigen::Vector3d position(0.4 * std::sin(t), 0.2 * t, 0.1 * std::cos(3 * t));
    trajectory.push_back(
        {50.0 + t, make_pose(position, Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d::UnitY()))});
  }
  return trajectory;
}

// The estimate: every third-and-a-third ground-truth pose (30 Hz), offset by 2 ms in time, moved
// into another world frame. Its poses equal the ground truth's at the matched instants.
Trajectory estimate_from(const Trajectory& gt, const Eigen::Isometry3d& T_est_gt) {
  Trajectory est;
  for (int k = 0;; ++k) {
    const auto index = static_cast<std::size_t>(std::lround(k * 100.0 / 30.0));
    if (index >= gt.size()) break;
    est.push_back({gt[index].timestamp + 0.002, T_est_gt * gt[index].T_world_camera});
  }
  return est;
}

TEST(EvalMetrics, ExactEstimateInAnotherFrameScoresZeroEverywhere) {
  const Trajectory gt = mocap_trajectory(3.0);
  const Eigen::Isometry3d T_est_gt =
      make_pose(Eigen::Vector3d(0.5, -1, 2), Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()));
  const Trajectory est = estimate_from(gt, T_est_gt);
  const auto metrics = evaluate(gt, est);
  ASSERT_TRUE(metrics.ok()) << metrics.error().describe();
  EXPECT_EQ(metrics->gt_poses, gt.size());
  EXPECT_EQ(metrics->est_poses, est.size());
  EXPECT_EQ(metrics->ate.matches.size(), est.size());
  EXPECT_NEAR(metrics->ate.stats.rmse, 0.0, 1e-9);
  EXPECT_TRUE(metrics->ate.T_gt_est.isApprox(T_est_gt.inverse(), 1e-9));
  EXPECT_EQ(metrics->rpe_frame.pairs.size(), est.size() - 1);
  EXPECT_GT(metrics->rpe_second.pairs.size(), 0u);
  EXPECT_NEAR(metrics->rpe_frame.trans_m.max, 0.0, 1e-9);
  EXPECT_NEAR(metrics->rpe_second.rot_deg.max, 0.0, 1e-6);
  EXPECT_DOUBLE_EQ(metrics->gt_span.begin, 50.0);
  EXPECT_DOUBLE_EQ(metrics->est_span.begin, 50.002);
}

TEST(EvalMetrics, JsonCarriesTheNamedKeysInMetresAndDegrees) {
  // Four poses on a plus; lifting two opposite ones by d leaves an aligned error of d/2 at every
  // pose (worked through in eval_ate_test.cpp), so ate_rmse is d/2.
  constexpr double d = 0.06;
  const Eigen::Vector3d plus[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  Trajectory gt, est;
  for (int k = 0; k < 4; ++k) {
    const Eigen::AngleAxisd still(0.0, Eigen::Vector3d::UnitX());
    gt.push_back({10.0 + 0.1 * k, make_pose(plus[k], still)});
    est.push_back(
        {10.0 + 0.1 * k, make_pose(plus[k] + Eigen::Vector3d(0, 0, k < 2 ? d : 0.0), still)});
  }
  const auto metrics = evaluate(gt, est);
  ASSERT_TRUE(metrics.ok()) << metrics.error().describe();
  const nlohmann::json json = nlohmann::json::parse(to_json(*metrics));
  ASSERT_TRUE(json.is_object());
  EXPECT_EQ(json.at("matched").get<int>(), 4);
  EXPECT_EQ(json.at("gt_poses").get<int>(), 4);
  EXPECT_NEAR(json.at("ate_rmse").get<double>(), d / 2, 1e-12);
  EXPECT_NEAR(json.at("ate_mean").get<double>(), d / 2, 1e-12);
  EXPECT_NEAR(json.at("ate_median").get<double>(), d / 2, 1e-12);
  EXPECT_NEAR(json.at("ate_max").get<double>(), d / 2, 1e-12);
  EXPECT_EQ(json.at("rpe_frame_pairs").get<int>(), 3);
  EXPECT_DOUBLE_EQ(json.at("rpe_frame_trans_rmse").get<double>(), metrics->rpe_frame.trans_m.rmse);
  EXPECT_TRUE(json.at("rpe_frame_rot_rmse_deg").is_number());
  // 0.3 s of poses: no pair is 1 s apart, so the per-second statistics are null, not 0.
  EXPECT_EQ(json.at("rpe_second_pairs").get<int>(), 0);
  EXPECT_TRUE(json.at("rpe_second_trans_rmse").is_null());
  EXPECT_TRUE(json.at("rpe_second_rot_rmse_deg").is_null());
  EXPECT_EQ(json.at("alignment_T_gt_est").size(), 7u);
  EXPECT_NEAR(json.at("alignment_T_gt_est").at(2).get<double>(), -d / 2, 1e-12);
}

TEST(EvalMetrics, RpeOptionsArePassedThrough) {
  const Trajectory gt = mocap_trajectory(3.0);
  const Trajectory est = estimate_from(gt, Eigen::Isometry3d::Identity());
  EvalOptions options;
  options.rpe_frame.delta = 5;
  options.rpe_second.delta = 2.0;
  const auto metrics = evaluate(gt, est, options);
  ASSERT_TRUE(metrics.ok());
  EXPECT_EQ(metrics->rpe_frame.pairs.size(), est.size() - 5);
  for (const auto& [k, j] : metrics->rpe_second.pairs) {
    EXPECT_NEAR(est[metrics->ate.matches[j].est_index].timestamp -
                    est[metrics->ate.matches[k].est_index].timestamp,
                2.0, 0.02);
  }
  const nlohmann::json json = nlohmann::json::parse(to_json(*metrics));
  EXPECT_DOUBLE_EQ(json.at("rpe_frame_delta").get<double>(), 5.0);
  EXPECT_DOUBLE_EQ(json.at("rpe_second_delta").get<double>(), 2.0);
}

TEST(EvalMetrics, FailsLikeAteWhenTooFewPosesMatch) {
  const Trajectory gt = mocap_trajectory(1.0);
  Trajectory est = estimate_from(gt, Eigen::Isometry3d::Identity());
  // The estimate's stamps are 2 ms after ground-truth stamps: a 1 ms window pairs nothing.
  const auto metrics = evaluate(gt, est, {.association = {.max_difference_s = 0.001}});
  ASSERT_FALSE(metrics.ok());
  EXPECT_NE(metrics.error().message.find("only 0 poses matched within 0.001 s"), std::string::npos)
      << metrics.error().message;
  EXPECT_FALSE(evaluate(gt, Trajectory{}).ok());
}

}  // namespace
}  // namespace imufusion
