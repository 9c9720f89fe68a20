// summarize_scan: the counts imufusion-scan's summary.json and the benchmarks report, from
// per-frame results alone.

#include "imufusion/scan_report.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace imufusion {
namespace {

// Frames with the given statuses; `recovered` marks the frames that ended a loss.
std::vector<FrameResult> frames(const std::vector<TrackingStatus>& statuses,
                                const std::vector<std::size_t>& recovered) {
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
  EXPECT_DOUBLE_EQ(s.median_icp_iterations,
                   10);  // seven of the ten frames ICP ran on are not tracking
  EXPECT_DOUBLE_EQ(s.median_icp_iterations_tracking, 2);             // frames 1, 9 and 10
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

// imufusion-scan sums its statistics frame by frame instead of keeping every FrameResult (1 KiB
// each): the same figures, the frames placed at finish() included.
TEST(ScanSummary, FrameByFrameGivesWhatSummarizeScanGives) {
  std::vector<FrameResult> scan = frames({T, T, L, L, R, L, L, R, R, T, T}, {9});
  for (std::size_t i = 0; i < scan.size(); ++i)
    scan[i].timings.total_ms = 10.0 + static_cast<double>(i % 4);
  scan[3].fused = true;
  scan[3].integration.pool_full = 5;
  scan[6].fused = true;
  scan[6].integration.pool_full = 1;
  ScanSummary summary;
  for (const FrameResult& f : scan) summary.add(f);
  summary.add_retracked(4);
  scan.back().retracked += 4;
  const ScanStatistics a = summary.statistics(), b = summarize_scan(scan);
  EXPECT_EQ(summary.frames(), scan.size());
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.fused, 2u);
  EXPECT_EQ(a.lost, b.lost);
  EXPECT_EQ(a.broken_recoveries, b.broken_recoveries);
  EXPECT_EQ(a.recovery_frames, b.recovery_frames);
  EXPECT_EQ(a.retracked, 4u);
  EXPECT_EQ(b.retracked, 4u);
  EXPECT_EQ(a.pool_full_frames, 2u);
  EXPECT_EQ(a.first_pool_full_frame, 3u);
  EXPECT_DOUBLE_EQ(a.median_icp_iterations, b.median_icp_iterations);
  EXPECT_DOUBLE_EQ(a.mean_icp_iterations, b.mean_icp_iterations);
  EXPECT_DOUBLE_EQ(a.median_frame_ms, 11.0);
  EXPECT_DOUBLE_EQ(a.fps, b.fps);
}

// The per-stage means are over all frames (a stage that did not run counts 0 ms); a kernel's
// mean sums its dispatches within a frame, and the kernels come slowest first.
TEST(ScanSummary, StageAndKernelMeansPerFrame) {
  std::vector<FrameResult> scan(4);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    FrameTimings& t = scan[i].timings;
    t.preprocess_ms = 2.0;
    t.icp_ms = i == 0 ? 0.0 : 4.0;
    t.raycast_ms = 1.0 + static_cast<double>(i);
    t.total_ms = t.preprocess_ms + t.icp_ms + t.raycast_ms;
    t.kernels = {{"bilateral[0]", 1.5}, {"icp_reduce[0]", 0.5}, {"icp_reduce[0]", 0.25}};
    if (i == 0) t.kernels.pop_back();
  }
  const ScanStatistics s = summarize_scan(scan);
  EXPECT_DOUBLE_EQ(s.mean_stage_ms.preprocess_ms, 2.0);
  EXPECT_DOUBLE_EQ(s.mean_stage_ms.icp_ms, 3.0);
  EXPECT_DOUBLE_EQ(s.mean_stage_ms.raycast_ms, 2.5);
  EXPECT_DOUBLE_EQ(s.mean_stage_ms.integrate_ms, 0.0);
  EXPECT_DOUBLE_EQ(s.mean_stage_ms.total_ms, 7.5);
  ASSERT_EQ(s.mean_kernels.size(), 2u);
  EXPECT_EQ(s.mean_kernels[0].kernel, "bilateral[0]");
  EXPECT_DOUBLE_EQ(s.mean_kernels[0].gpu_ms, 1.5);
  EXPECT_DOUBLE_EQ(s.mean_kernels[0].dispatches, 1.0);
  EXPECT_EQ(s.mean_kernels[1].kernel, "icp_reduce[0]");
  EXPECT_DOUBLE_EQ(s.mean_kernels[1].gpu_ms, (0.5 + 3 * 0.75) / 4);
  EXPECT_DOUBLE_EQ(s.mean_kernels[1].dispatches, 7.0 / 4);
}

}  // namespace
}  // namespace imufusion
