#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

Eigen::Isometry3d make_pose(const Eigen::Vector3d& position, const Eigen::Quaterniond& rotation) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = position;
  return pose;
}

// A non-planar, non-symmetric 30 Hz path with changing orientation, so that the alignment is
// fully determined.
Trajectory wavy_trajectory(int count) {
  Trajectory trajectory;
  for (int k = 0; k < count; ++k) {
    const double t = k / 30.0;
    const Eigen::Vector3d position(0.5 * std::sin(1.3 * t), 0.3 * t, 0.2 * std::cos(2.1 * t));
    const Eigen::Quaterniond rotation(
        Eigen::AngleAxisd(0.4 * t, Eigen::Vector3d(1, 2, 3).normalized()));
    trajectory.push_back({100.0 + t, make_pose(position, rotation)});
  }
  return trajectory;
}

Eigen::Isometry3d some_rigid_transform() {
  return make_pose(
      Eigen::Vector3d(1.5, -2.0, 0.7),
      Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(-1, 0.5, 2).normalized())));
}

TEST(EvalAte, IdenticalTrajectoriesHaveZeroErrorAndIdentityAlignment) {
  const Trajectory gt = wavy_trajectory(60);
  const auto ate = evaluate_ate(gt, gt);
  ASSERT_TRUE(ate.ok()) << ate.error().describe();
  EXPECT_EQ(ate->matches.size(), 60u);
  EXPECT_EQ(ate->stats.count, 60u);
  EXPECT_NEAR(ate->stats.rmse, 0.0, 1e-12);
  EXPECT_NEAR(ate->stats.max, 0.0, 1e-12);
  EXPECT_TRUE(ate->T_gt_est.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
}

TEST(EvalAte, RigidlyMovedEstimateAlignsBackExactly) {
  // est = T_est_gt * gt, so p_est = T p_gt and the alignment p_gt ~ T_gt_est p_est must be T^-1.
  const Trajectory gt = wavy_trajectory(60);
  const Eigen::Isometry3d T_est_gt = some_rigid_transform();
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_world_camera = T_est_gt * pose.T_world_camera;

  const auto ate = evaluate_ate(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.error().describe();
  EXPECT_NEAR(ate->stats.rmse, 0.0, 1e-9);
  EXPECT_NEAR(ate->stats.max, 0.0, 1e-9);
  EXPECT_TRUE(ate->T_gt_est.matrix().isApprox(T_est_gt.inverse().matrix(), 1e-9))
      << ate->T_gt_est.matrix() << "\n vs \n"
      << T_est_gt.inverse().matrix();
}

// Four poses on the unit "plus" A(1,0,0) B(-1,0,0) C(0,1,0) D(0,-1,0); the estimate lifts A and
// B by d along z. Hand computation of the aligned errors:
//   estimate centroid (0,0,d/2), ground-truth centroid 0; centred estimate points
//   A'(1,0,d/2) B'(-1,0,d/2) C'(0,1,-d/2) D'(0,-1,-d/2).
//   Cross-covariance H = sum_i est'_i gt_i^T: A' and B' add (1,0,+-d/2)(+-1,0,0)^T, i.e. column 0
//   gets (1,0,d/2) + (1,0,-d/2) = (2,0,0); likewise column 1 gets (0,2,0); H = diag(2,2,0),
//   symmetric and positive semi-definite, so the best rotation is the identity.
//   The alignment is then the translation (0,0,-d/2): every aligned point is d/2 from its ground
//   truth (A,B above, C,D below). RMSE = mean = median = min = max = d/2, std = 0.
TEST(EvalAte, SymmetricDisplacementThatAlignmentCannotAbsorb) {
  constexpr double d = 0.08;  // metres
  const std::vector<Eigen::Vector3d> plus{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  Trajectory gt, est;
  for (std::size_t k = 0; k < plus.size(); ++k) {
    const double t = 10.0 + 0.1 * static_cast<double>(k);
    gt.push_back({t, make_pose(plus[k], Eigen::Quaterniond::Identity())});
    const Eigen::Vector3d lifted =
        plus[k] + (k < 2 ? Eigen::Vector3d(0, 0, d) : Eigen::Vector3d::Zero());
    est.push_back({t, make_pose(lifted, Eigen::Quaterniond::Identity())});
  }
  const auto ate = evaluate_ate(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.error().describe();
  EXPECT_NEAR(ate->stats.rmse, d / 2, 1e-12);
  EXPECT_NEAR(ate->stats.mean, d / 2, 1e-12);
  EXPECT_NEAR(ate->stats.median, d / 2, 1e-12);
  EXPECT_NEAR(ate->stats.min, d / 2, 1e-12);
  EXPECT_NEAR(ate->stats.max, d / 2, 1e-12);
  EXPECT_NEAR(ate->stats.std, 0.0, 1e-12);
  EXPECT_TRUE(ate->T_gt_est.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(ate->T_gt_est.translation().isApprox(Eigen::Vector3d(0, 0, -d / 2), 1e-12));

  // Moving the whole estimate rigidly changes the alignment, not the errors.
  const Eigen::Isometry3d T_moved_est = some_rigid_transform();
  Trajectory moved = est;
  for (StampedPose& pose : moved) pose.T_world_camera = T_moved_est * pose.T_world_camera;
  const auto moved_ate = evaluate_ate(gt, moved);
  ASSERT_TRUE(moved_ate.ok());
  EXPECT_NEAR(moved_ate->stats.rmse, d / 2, 1e-9);
  EXPECT_NEAR(moved_ate->stats.max, d / 2, 1e-9);
}

TEST(EvalAte, ScaleErrorIsNotForgiven) {
  // Alignment has no scale: an estimate at twice the size keeps an error. For points on a line
  // through the centroid, x_est = 2 x_gt; the best rigid map is the translation that matches
  // centroids, leaving error |x_gt| at each point: gt x = -1, 0, 1 gives errors 1, 0, 1 and
  // RMSE sqrt(2/3).
  Trajectory gt, est;
  for (int k = 0; k < 3; ++k) {
    const double x = k - 1.0;
    gt.push_back({1.0 + k, make_pose(Eigen::Vector3d(x, 0, 0), Eigen::Quaterniond::Identity())});
    est.push_back(
        {1.0 + k, make_pose(Eigen::Vector3d(2 * x, 0, 0), Eigen::Quaterniond::Identity())});
  }
  const auto ate = evaluate_ate(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.error().describe();
  EXPECT_NEAR(ate->stats.rmse, std::sqrt(2.0 / 3.0), 1e-9);
  EXPECT_NEAR(ate->stats.median, 1.0, 1e-9);
  EXPECT_NEAR(ate->stats.min, 0.0, 1e-9);
}

TEST(EvalAte, TooFewMatchesSaysHowManyAndShowsBothTimeSpans) {
  const Trajectory gt = wavy_trajectory(30);  // 100.000 .. 100.967 s
  Trajectory est = wavy_trajectory(30);
  // Only the first two estimate poses overlap the ground truth; the rest are 50 s later.
  for (std::size_t k = 2; k < est.size(); ++k) est[k].timestamp += 50.0;
  const auto ate = evaluate_ate(gt, est);
  ASSERT_FALSE(ate.ok());
  EXPECT_EQ(ate.error().code, ErrorCode::kInvalidArgument);
  const std::string& message = ate.error().message;
  EXPECT_NE(message.find("only 2 poses matched within 0.02 s"), std::string::npos) << message;
  EXPECT_NE(message.find("30 poses spanning 100.000000 .. 100.966667 s"), std::string::npos)
      << message;
  EXPECT_NE(message.find("30 poses spanning 100.000000 .. 150.966667 s"), std::string::npos)
      << message;
}

TEST(EvalAte, DisjointSpansAreCalledOutAsAPossibleClockOffset) {
  const Trajectory gt = wavy_trajectory(30);
  Trajectory est = wavy_trajectory(30);
  for (StampedPose& pose : est) pose.timestamp -= 100.0;  // estimate on a clock starting at 0
  const auto ate = evaluate_ate(gt, est);
  ASSERT_FALSE(ate.ok());
  EXPECT_NE(ate.error().message.find("only 0 poses matched"), std::string::npos);
  EXPECT_NE(ate.error().message.find("clock offset"), std::string::npos) << ate.error().message;

  // The offset that undoes the shift pairs them all; a wrong one is named in the message.
  const auto undone = evaluate_ate(gt, est, {.max_difference_s = 0.02, .time_offset_s = 100.0});
  ASSERT_TRUE(undone.ok()) << undone.error().describe();
  EXPECT_EQ(undone->matches.size(), 30u);
  const auto wrong = evaluate_ate(gt, est, {.max_difference_s = 0.02, .time_offset_s = 50.0});
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("shifted by +50 s"), std::string::npos)
      << wrong.error().message;
}

TEST(EvalAte, EmptyTrajectoriesAreErrors) {
  const Trajectory gt = wavy_trajectory(10);
  const auto no_est = evaluate_ate(gt, Trajectory{});
  ASSERT_FALSE(no_est.ok());
  EXPECT_NE(no_est.error().message.find("estimate trajectory is empty"), std::string::npos);
  const auto no_gt = evaluate_ate(Trajectory{}, gt);
  ASSERT_FALSE(no_gt.ok());
  EXPECT_NE(no_gt.error().message.find("ground-truth trajectory is empty"), std::string::npos);
}

TEST(EvalAte, ExplicitMatchesAreCheckedAndUsed) {
  const Trajectory gt = wavy_trajectory(10);
  const std::vector<PoseMatch> out_of_range{{0, 0}, {1, 1}, {2, 10}};
  EXPECT_FALSE(evaluate_ate(gt, gt, out_of_range).ok());
  // Pairing pose k with pose k of a shifted copy: the explicit pairs are used, not timestamps.
  Trajectory shifted = gt;
  for (StampedPose& pose : shifted) pose.timestamp += 5.0;
  const std::vector<PoseMatch> diagonal{{0, 0}, {3, 3}, {6, 6}, {9, 9}};
  const auto ate = evaluate_ate(gt, shifted, diagonal);
  ASSERT_TRUE(ate.ok()) << ate.error().describe();
  EXPECT_EQ(ate->errors_m.size(), 4u);
  EXPECT_NEAR(ate->stats.max, 0.0, 1e-12);
}

TEST(EvalErrorStats, MatchesNumpyDefinitions) {
  // mean 2.5; median of an even count averages 2 and 3; rmse sqrt((1+4+9+16)/4) = sqrt(7.5);
  // population std sqrt((2.25+0.25+0.25+2.25)/4) = sqrt(1.25).
  const ErrorStats stats = compute_error_stats({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(stats.count, 4u);
  EXPECT_DOUBLE_EQ(stats.mean, 2.5);
  EXPECT_DOUBLE_EQ(stats.median, 2.5);
  EXPECT_DOUBLE_EQ(stats.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(stats.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(stats.min, 1.0);
  EXPECT_DOUBLE_EQ(stats.max, 4.0);
  EXPECT_DOUBLE_EQ(compute_error_stats({5.0, 1.0, 3.0}).median, 3.0);

  const ErrorStats empty = compute_error_stats({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_TRUE(std::isnan(empty.rmse));
  EXPECT_TRUE(std::isnan(empty.median));
}

}  // namespace
}  // namespace imufusion
