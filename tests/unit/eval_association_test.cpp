#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {
namespace {

Trajectory stamps(const std::vector<double>& times) {
  Trajectory trajectory;
  for (double t : times) trajectory.push_back({t, Eigen::Isometry3d::Identity()});
  return trajectory;
}

// TUM-like clock values (~1.3e9 s) keep the test honest about double precision at 10 ms scales.
constexpr double kStart = 1305031101.0;

std::vector<double> regular(double start, double period, int count) {
  std::vector<double> times;
  for (int k = 0; k < count; ++k) times.push_back(start + period * k);
  return times;
}

TEST(EvalAssociation, ShiftOf10msMatchesEveryPose) {
  const Trajectory gt = stamps(regular(kStart, 0.1, 20));
  const Trajectory est = stamps(regular(kStart + 0.010, 0.1, 20));
  const auto matches = associate(gt, est);
  ASSERT_TRUE(matches.ok()) << matches.error().describe();
  ASSERT_EQ(matches->size(), 20u);
  for (std::size_t k = 0; k < matches->size(); ++k) {
    EXPECT_EQ((*matches)[k], (PoseMatch{k, k}));
  }
}

TEST(EvalAssociation, ShiftOf30msMatchesNothingAtTheDefault20msWindow) {
  const Trajectory gt = stamps(regular(kStart, 0.1, 20));
  const Trajectory est = stamps(regular(kStart + 0.030, 0.1, 20));
  const auto matches = associate(gt, est);
  ASSERT_TRUE(matches.ok());
  EXPECT_TRUE(matches->empty());

  // A wider window, or the offset that undoes the shift, matches them all again.
  EXPECT_EQ(associate(gt, est, {.max_difference_s = 0.04})->size(), 20u);
  EXPECT_EQ(associate(gt, est, {.max_difference_s = 0.02, .time_offset_s = -0.030})->size(), 20u);
}

TEST(EvalAssociation, GreedyByTimeDifferenceUsesEachPoseOnce) {
  // Candidates within 20 ms: (A,X) 10 ms, (B,X) 2 ms, (B,Y) 13 ms; (A,Y) is 25 ms, too far.
  // associate.py takes (B,X) first; then A's only candidate X and Y's only candidate B are used,
  // so one pair results, although A-X plus B-Y would have paired everything, and although X is
  // the nearest estimate for both A and B.
  const Trajectory gt = stamps({kStart + 0.000, kStart + 0.012});   // A, B
  const Trajectory est = stamps({kStart + 0.010, kStart + 0.025});  // X, Y
  const auto matches = associate(gt, est);
  ASSERT_TRUE(matches.ok());
  ASSERT_EQ(matches->size(), 1u);
  EXPECT_EQ((*matches)[0], (PoseMatch{1, 0}));
}

TEST(EvalAssociation, HundredHertzGroundTruthAgainstThirtyHertzEstimate) {
  // Every estimate stamp lies within 5 ms of a 100 Hz ground-truth stamp, so all pair, each with
  // its nearest ground-truth pose, and no ground-truth pose twice.
  const Trajectory gt = stamps(regular(kStart, 0.01, 300));
  Trajectory est = stamps(regular(kStart + 0.001, 1.0 / 30.0, 90));
  const auto matches = associate(gt, est);
  ASSERT_TRUE(matches.ok());
  ASSERT_EQ(matches->size(), est.size());
  std::set<std::size_t> used_gt;
  for (const PoseMatch& m : *matches) {
    EXPECT_TRUE(used_gt.insert(m.gt_index).second);
    const double dt = std::abs(gt[m.gt_index].timestamp - est[m.est_index].timestamp);
    EXPECT_LE(dt, 0.005 + 1e-6);
  }
}

TEST(EvalAssociation, UnsortedInputGivesMatchesSortedByGroundTruthTime) {
  const Trajectory gt = stamps({kStart + 0.2, kStart + 0.0, kStart + 0.1});
  const Trajectory est = stamps({kStart + 0.105, kStart + 0.205, kStart + 0.005});
  const auto matches = associate(gt, est);
  ASSERT_TRUE(matches.ok());
  const std::vector<PoseMatch> expected{{1, 2}, {2, 0}, {0, 1}};
  EXPECT_EQ(*matches, expected);
}

TEST(EvalAssociation, EmptyInputsGiveNoMatches) {
  const auto matches = associate(Trajectory{}, stamps({kStart}));
  ASSERT_TRUE(matches.ok());
  EXPECT_TRUE(matches->empty());
}

TEST(EvalAssociation, RejectsBadOptionsAndTimestamps) {
  const Trajectory gt = stamps({kStart});
  EXPECT_FALSE(associate(gt, gt, {.max_difference_s = 0.0}).ok());
  EXPECT_FALSE(associate(gt, gt, {.max_difference_s = -1.0}).ok());
  EXPECT_FALSE(associate(gt, gt, {.max_difference_s = 0.02, .time_offset_s = NAN}).ok());
  const auto bad = associate(gt, stamps({kStart, INFINITY}));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("estimate pose 1"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace imufusion
