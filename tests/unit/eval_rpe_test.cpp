#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

Eigen::Isometry3d make_pose(const Eigen::Vector3d& position, const Eigen::AngleAxisd& rotation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.toRotationMatrix();
  pose.translation() = position;
  return pose;
}

Trajectory wavy_trajectory(int count) {
  Trajectory trajectory;
  for (int k = 0; k < count; ++k) {
    const double t = k / 30.0;
    const Eigen::Vector3d position(0.5 * std::sin(1.3 * t), 0.3 * t, 0.2 * std::cos(2.1 * t));
    const Eigen::AngleAxisd rotation(0.4 * t, Eigen::Vector3d(1, 2, 3).normalized());
    trajectory.push_back({100.0 + t, make_pose(position, rotation)});
  }
  return trajectory;
}

std::vector<PoseMatch> match_all(const Trajectory& gt, const Trajectory& est) {
  auto matches = associate(gt, est);
  EXPECT_TRUE(matches.ok());
  return matches.ok() ? *matches : std::vector<PoseMatch>{};
}

// A camera spinning about the world z axis at spin_deg_s while climbing along z at climb_m_s,
// sampled at 30 Hz. Rotation about z commutes with translation along z, so the relative motion
// over dt is exactly (Rz(spin dt), (0, 0, climb dt)) wherever it starts.
Trajectory helix(int count, double spin_deg_s, double climb_m_s, const Eigen::Isometry3d& world) {
  Trajectory trajectory;
  for (int k = 0; k < count; ++k) {
    const double t = k / 30.0;
    const Eigen::Isometry3d local =
        make_pose(Eigen::Vector3d(0, 0, climb_m_s * t),
                  Eigen::AngleAxisd(spin_deg_s * kDegree * t, Eigen::Vector3d::UnitZ()));
    trajectory.push_back({1305031101.0 + t, world * local});
  }
  return trajectory;
}

TEST(EvalRpe, ConstantExtraMotionPerFrame) {
  // The estimate's step is the ground truth's step followed by a constant error Delta (1 degree
  // about a tilted axis, 1 cm along y): P_{k+1} = P_k (Q_k^-1 Q_{k+1}) Delta, so
  // E_k = (Q_k^-1 Q_{k+1})^-1 (P_k^-1 P_{k+1}) = Delta exactly for every k.
  const Trajectory gt = wavy_trajectory(40);
  const Eigen::Isometry3d delta =
      make_pose(Eigen::Vector3d(0, 0.01, 0),
                Eigen::AngleAxisd(1.0 * kDegree, Eigen::Vector3d(0.3, -1, 0.5).normalized()));
  Trajectory est = gt;
  est[0].T_world_camera =
      make_pose(Eigen::Vector3d(4, 5, 6), Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()));
  for (std::size_t k = 0; k + 1 < gt.size(); ++k) {
    est[k + 1].T_world_camera =
        est[k].T_world_camera * gt[k].T_world_camera.inverse() * gt[k + 1].T_world_camera * delta;
  }
  const auto rpe = evaluate_rpe(gt, est, match_all(gt, est), {});
  ASSERT_TRUE(rpe.ok()) << rpe.error().describe();
  ASSERT_EQ(rpe->pairs.size(), 39u);
  EXPECT_EQ(rpe->pairs.front(), (std::pair<std::size_t, std::size_t>{0, 1}));
  EXPECT_NEAR(rpe->rot_deg.rmse, 1.0, 1e-9);
  EXPECT_NEAR(rpe->rot_deg.min, 1.0, 1e-9);
  EXPECT_NEAR(rpe->rot_deg.max, 1.0, 1e-9);
  EXPECT_NEAR(rpe->trans_m.rmse, 0.01, 1e-12);
  EXPECT_NEAR(rpe->trans_m.max, 0.01, 1e-12);
  EXPECT_NEAR(rpe->trans_m.std, 0.0, 1e-12);
}

TEST(EvalRpe, RelativeErrorIgnoresWhereEachWorldFrameIs) {
  const Trajectory gt = wavy_trajectory(40);
  const Eigen::Isometry3d T_other_world = make_pose(
      Eigen::Vector3d(-3, 1, 2), Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 1, 0).normalized()));
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_world_camera = T_other_world * pose.T_world_camera;
  const auto rpe = evaluate_rpe(gt, est, match_all(gt, est), {});
  ASSERT_TRUE(rpe.ok());
  EXPECT_NEAR(rpe->trans_m.max, 0.0, 1e-9);
  EXPECT_NEAR(rpe->rot_deg.max, 0.0, 1e-6);
}

TEST(EvalRpe, FrameDeltaOfTwoPairsEverySecondNeighbour) {
  const Trajectory gt = wavy_trajectory(10);
  const auto rpe =
      evaluate_rpe(gt, gt, match_all(gt, gt), {.delta = 2, .unit = DeltaUnit::kFrames});
  ASSERT_TRUE(rpe.ok());
  ASSERT_EQ(rpe->pairs.size(), 8u);
  EXPECT_EQ(rpe->pairs.back(), (std::pair<std::size_t, std::size_t>{7, 9}));
}

// Ground truth spins at 20 deg/s and climbs 0.30 m/s; the estimate spins at 23 deg/s and climbs
// 0.33 m/s (and lives in another world frame). Over any 1 s: E = (Rz(3 deg), (0, 0, 0.03 m)),
// so the per-second errors are 3 deg and 0.03 m, and per frame (1/30 s) 0.1 deg and 0.001 m.
class EvalRpeHelix : public ::testing::Test {
 protected:
  const Eigen::Isometry3d T_est_world_ =
      make_pose(Eigen::Vector3d(1, 2, 3), Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()));
  const Trajectory gt_ = helix(91, 20.0, 0.30, Eigen::Isometry3d::Identity());  // 0 .. 3 s
  const Trajectory est_ = helix(91, 23.0, 0.33, T_est_world_);
};

TEST_F(EvalRpeHelix, PerSecondOnA30HzTrajectory) {
  const auto rpe =
      evaluate_rpe(gt_, est_, match_all(gt_, est_),
                   {.delta = 1.0, .unit = DeltaUnit::kSeconds, .time_tolerance_s = 0.02});
  ASSERT_TRUE(rpe.ok()) << rpe.error().describe();
  // Poses 0..60 have a partner exactly 30 frames (1 s) later; 61..90 have none within 20 ms.
  ASSERT_EQ(rpe->pairs.size(), 61u);
  for (std::size_t p = 0; p < rpe->pairs.size(); ++p) {
    EXPECT_EQ(rpe->pairs[p], (std::pair<std::size_t, std::size_t>{p, p + 30}));
  }
  EXPECT_NEAR(rpe->rot_deg.rmse, 3.0, 1e-9);
  EXPECT_NEAR(rpe->rot_deg.max, 3.0, 1e-9);
  EXPECT_NEAR(rpe->trans_m.rmse, 0.03, 1e-9);
  EXPECT_NEAR(rpe->trans_m.median, 0.03, 1e-9);
}

TEST_F(EvalRpeHelix, PerFrameOnTheSameTrajectory) {
  const auto rpe = evaluate_rpe(gt_, est_, match_all(gt_, est_), {});
  ASSERT_TRUE(rpe.ok());
  ASSERT_EQ(rpe->pairs.size(), 90u);
  EXPECT_NEAR(rpe->rot_deg.rmse, 0.1, 1e-9);
  EXPECT_NEAR(rpe->trans_m.rmse, 0.001, 1e-9);
}

TEST_F(EvalRpeHelix, PerSecondSkipsPosesWithNoPartnerWithinTolerance) {
  // Drop estimate frames 45..50 (1.500 .. 1.667 s). Poses 15..20 then find their nearest
  // partner 1/30 s or more from t + 1 s (beyond the 20 ms tolerance) and are skipped, and 45..50
  // are gone themselves: 61 - 6 - 6 = 49 pairs, each still exactly 1 s long.
  Trajectory est;
  for (std::size_t k = 0; k < est_.size(); ++k) {
    if (k < 45 || k > 50) est.push_back(est_[k]);
  }
  const std::vector<PoseMatch> matches = match_all(gt_, est);
  ASSERT_EQ(matches.size(), 85u);
  const auto rpe = evaluate_rpe(gt_, est, matches, {.delta = 1.0, .unit = DeltaUnit::kSeconds});
  ASSERT_TRUE(rpe.ok());
  EXPECT_EQ(rpe->pairs.size(), 49u);
  for (const auto& [k, j] : rpe->pairs) {
    const std::size_t gt_k = matches[k].gt_index;
    EXPECT_FALSE(gt_k >= 15 && gt_k <= 20) << "pose " << gt_k << " should have been skipped";
    EXPECT_EQ(matches[j].gt_index, gt_k + 30);
  }
  EXPECT_NEAR(rpe->rot_deg.max, 3.0, 1e-9);
  EXPECT_NEAR(rpe->trans_m.max, 0.03, 1e-9);
}

TEST(EvalRpe, TrajectoryShorterThanTheDeltaGivesNoPairsNotAnError) {
  const Trajectory gt = wavy_trajectory(15);  // 0.47 s
  const auto rpe =
      evaluate_rpe(gt, gt, match_all(gt, gt), {.delta = 1.0, .unit = DeltaUnit::kSeconds});
  ASSERT_TRUE(rpe.ok());
  EXPECT_TRUE(rpe->pairs.empty());
  EXPECT_EQ(rpe->trans_m.count, 0u);
  EXPECT_TRUE(std::isnan(rpe->trans_m.rmse));
}

TEST(EvalRpe, RejectsInvalidDeltasAndTooFewMatches) {
  const Trajectory gt = wavy_trajectory(10);
  const std::vector<PoseMatch> matches = match_all(gt, gt);
  EXPECT_FALSE(evaluate_rpe(gt, gt, matches, {.delta = 0.0}).ok());
  EXPECT_FALSE(evaluate_rpe(gt, gt, matches, {.delta = 1.5, .unit = DeltaUnit::kFrames}).ok());
  EXPECT_TRUE(evaluate_rpe(gt, gt, matches, {.delta = 1.5, .unit = DeltaUnit::kSeconds}).ok());
  EXPECT_FALSE(evaluate_rpe(gt, gt, matches,
                            {.delta = 1.0, .unit = DeltaUnit::kSeconds, .time_tolerance_s = -1.0})
                   .ok());
  EXPECT_FALSE(evaluate_rpe(gt, gt, {matches.front()}, {}).ok());
  EXPECT_FALSE(evaluate_rpe(gt, gt, {{0, 0}, {1, 10}}, {}).ok());
}

}  // namespace
}  // namespace imufusion
