// summarize_scan: the counts imufusion-scan's summary.json and the benchmarks report, from
// per-frame results alone.

#include <gtest/gtest.h>

#include <vector>

#include "imufusion/scan_report.hpp"

namespace imufusion {
namespace {

// Frames with the given statuses; `recovered` marks the frames that ended a loss.
std::vector<FrameResult> frames(const std::vector<TrackingStatus>& statuses, const std::vector<std::size_t>& recovered) {
  std::vector<FrameResult> out(statuses.size());
  for (std::size_t i = 0; i < statuses.size(); ++i) {
    out[i].index = i;
    out[i].status = statuses[i];
    out[i].icp_ran = i > 0;
    out[i].icp.quality.iterations = statuses[i] == TrackingStatus::kTracking ? 2 : 10;
  }
  for (std::size_t i : recovered) out[i].recovered = true;
  return out;
}

constexpr auto T = TrackingStatus::kTracking;
constexpr auto L = TrackingStatus::kLost;
constexpr auto R = TrackingStatus::kRecovering;

TEST(SummarizeScan, CountsARecoveryThatBrokeApartFromTheOneThatEndedTheLoss) {
  // Lost at 2, a recovering frame at 4 broken by 5, recovering 7-8, tracking again at 9.
  const ScanStatistics s = summarize_scan(frames({T, T, L, L, R, L, L, R, R, T, T}, {9}));
  EXPECT_EQ(s.frames, 11u);
  EXPECT_EQ(s.lost, 4u);
  EXPECT_EQ(s.recovering, 3u);
  EXPECT_EQ(s.recoveries, 1u);
  EXPECT_EQ(s.broken_recoveries, 1u);
  ASSERT_EQ(s.recovery_frames.size(), 1u);
  EXPECT_EQ(s.recovery_frames[0], 7u);  // from the first lost frame (2) to the one that tracked (9)
  EXPECT_DOUBLE_EQ(s.median_icp_iterations, 10);  // seven of the ten frames ICP ran on are not tracking
  EXPECT_DOUBLE_EQ(s.median_icp_iterations_tracking, 2);  // frames 1, 9 and 10
  EXPECT_DOUBLE_EQ(s.mean_icp_iterations, (3 * 2 + 7 * 10) / 10.0);  // frame 0 ran no ICP
}

TEST(SummarizeScan, ARecoveryThatEndsTheLossIsNotBroken) {
  const ScanStatistics s = summarize_scan(frames({T, L, R, R, T, L, R, T}, {4, 7}));
  EXPECT_EQ(s.recoveries, 2u);
  EXPECT_EQ(s.broken_recoveries, 0u);
  EXPECT_EQ(s.recovery_frames, (std::vector<std::size_t>{3, 2}));
}

TEST(SummarizeScan, AScanThatEndsWhileRecoveringHasNoRecoveryAndNoBreak) {
  const ScanStatistics s = summarize_scan(frames({T, L, L, R, R}, {}));
  EXPECT_EQ(s.recoveries, 0u);
  EXPECT_EQ(s.broken_recoveries, 0u);
  EXPECT_TRUE(s.recovery_frames.empty());
}

}  // namespace
}  // namespace imufusion
