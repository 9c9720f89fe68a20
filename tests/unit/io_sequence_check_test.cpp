#include <gtest/gtest.h>

#include "imufusion/image_io.hpp"
#include "io/sequence_check.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;
using testing::write_text;

TEST(StreamTiming, MedianRateAndGaps) {
  // Intervals 0.1 x 4, then 0.3 (a gap), then 0.1, 0.16 (over 1.5x: a gap), 0.14 (not).
  const std::vector<double> stamps = {0.0, 0.1, 0.2, 0.3, 0.4, 0.7, 0.8, 0.96, 1.1};
  const io::StreamTiming timing = io::stream_timing(stamps);
  EXPECT_EQ(timing.count, 9u);
  EXPECT_NEAR(timing.median_interval, 0.1, 1e-12);
  EXPECT_NEAR(timing.rate_hz, 10.0, 1e-9);
  ASSERT_EQ(timing.gaps.size(), 2u);
  EXPECT_DOUBLE_EQ(timing.gaps[0].after, 0.4);
  EXPECT_NEAR(timing.gaps[0].length, 0.3, 1e-12);
  EXPECT_DOUBLE_EQ(timing.gaps[1].after, 0.8);
}

TEST(StreamTiming, EvenCountMedianAndShortStreams) {
  EXPECT_NEAR(io::stream_timing({0.0, 1.0, 3.0}).median_interval, 1.5, 1e-12);
  EXPECT_EQ(io::stream_timing({5.0}).median_interval, 0.0);
  EXPECT_EQ(io::stream_timing({}).count, 0u);
}

// Four depth frames at 0, 1, 2, 3 s; IMU only up to 1.5 s; ground truth near frames 0 and 2.
TEST(SequenceCheck, CoverageOfImuAndGroundTruth) {
  TempDir dir;
  std::string depth;
  for (int i = 0; i < 4; ++i) {
    const std::string name = "depth/" + std::to_string(i) + ".png";
    std::filesystem::create_directories(dir / "depth");
    ASSERT_TRUE(write_depth_png(dir / name, testing::make_depth(8, 8, i)).ok());
    depth += std::to_string(i) + " " + name + "\n";
  }
  write_text(dir / "depth.txt", depth);
  write_text(dir / "calibration.txt", "3 3 1.5 1\n");
  write_text(dir / "imu.txt", "-0.5 0 0 0 0 0 0\n0.5 0 0 0 0 0 0\n1.5 0 0 0 0 0 0\n");
  write_text(dir / "groundtruth.txt", "0.01 0 0 0 0 0 0 1\n2.03 0 0 0 0 0 0 1\n");
  std::size_t last_progress = 0;
  const io::SequenceCheck check =
      io::check_sequence(dir.path(), [&](std::size_t done, std::size_t total) {
        EXPECT_EQ(total, 4u);
        last_progress = done;
      });
  EXPECT_EQ(last_progress, 4u);
  EXPECT_TRUE(check.scannable);
  EXPECT_EQ(check.depth_decoded, 4u);
  EXPECT_FALSE(check.imu_spans_frames);
  EXPECT_EQ(check.frames_without_imu, 1u);  // (2, 3] holds no sample
  EXPECT_FALSE(check.ground_truth_spans_frames);
  EXPECT_EQ(check.frames_with_ground_truth, 1u);  // only frame 0 has a pose within 20 ms
  EXPECT_EQ(check.warnings.size(), 3u);
}

TEST(SequenceCheck, CollectsEveryProblem) {
  TempDir dir;
  std::filesystem::create_directories(dir / "depth");
  ASSERT_TRUE(write_depth_png(dir / "depth/a.png", testing::make_depth(8, 8, 1)).ok());
  write_text(dir / "depth/b.png", "not a png");
  write_text(dir / "depth.txt", "1 depth/a.png\n2 depth/b.png\n3 depth/missing.png\n");
  write_text(dir / "imu.txt", "1 0 0 0 0 0\n");
  const io::SequenceCheck check = io::check_sequence(dir.path(), nullptr);
  EXPECT_FALSE(check.scannable);
  // depth.txt:3 missing, imu.txt:1 malformed, depth/b.png not a PNG, no calibration.txt.
  ASSERT_EQ(check.index.problems.size(), 4u);
  std::string all;
  for (const Error& problem : check.index.problems) all += problem.message + "\n";
  EXPECT_NE(all.find((dir / "depth.txt").string() + ":3:"), std::string::npos) << all;
  EXPECT_NE(all.find((dir / "imu.txt").string() + ":1:"), std::string::npos) << all;
  EXPECT_NE(all.find((dir / "depth/b.png").string()), std::string::npos) << all;
  EXPECT_NE(all.find("pass intrinsics"), std::string::npos) << all;
}

}  // namespace
}  // namespace imufusion
