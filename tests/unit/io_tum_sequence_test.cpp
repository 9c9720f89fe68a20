// Reads the shared TUM fr1/xyz sample (when present next to the repository) as it is.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "imufusion/sequence.hpp"

namespace imufusion {
namespace {

const std::filesystem::path kSequence =
    std::filesystem::path(IMUFUSION_SOURCE_DIR) / ".." / "shared" / "datasets" / "tum_fr1_xyz";

class TumSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(kSequence / "depth.txt")) {
      GTEST_SKIP() << kSequence << " is absent (it is not part of the repository)";
    }
  }
};

TEST_F(TumSequence, OpensWithAllStreams) {
  auto reader = SequenceReader::open(kSequence);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->frame_count(), 798u);
  ASSERT_TRUE(reader->intrinsics().has_value());
  const Intrinsics& k = *reader->intrinsics();
  EXPECT_EQ(k.fx, 517.3);
  EXPECT_EQ(k.fy, 516.5);
  EXPECT_EQ(k.cx, 318.6);
  EXPECT_EQ(k.cy, 255.3);
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_EQ(reader->info().depth_scale, 5000.0);
  EXPECT_TRUE(reader->has_imu());
  EXPECT_GT(reader->imu().size(), 5000u);
  EXPECT_TRUE(reader->has_ground_truth());
  EXPECT_FALSE(reader->info().accelerometer.empty());
  // rgb and depth are offset by about 15 ms: nearly every depth frame finds a colour frame.
  const auto& match = reader->info().color_of_depth;
  const auto matched = std::count_if(match.begin(), match.end(), [](int j) { return j >= 0; });
  EXPECT_GT(matched, 780);
}

TEST_F(TumSequence, DecodesFirstAndLastFrames) {
  auto reader = SequenceReader::open(kSequence);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  for (std::size_t index : {std::size_t{0}, reader->frame_count() - 1}) {
    auto frame = reader->frame(index);
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    EXPECT_EQ(frame->depth.width, 640);
    EXPECT_EQ(frame->depth.height, 480);
    const auto valid = std::count_if(frame->depth.data.begin(), frame->depth.data.end(),
                                     [](std::uint16_t d) { return d > 0; });
    EXPECT_GT(valid, 640 * 480 / 2);
    ASSERT_TRUE(frame->color.has_value());
    EXPECT_EQ(frame->color->width, 640);
    EXPECT_LT(std::abs(frame->color_timestamp - frame->timestamp), 0.02);
    EXPECT_FALSE(frame->imu.empty());
  }
  // Frame 1 gets the samples of one 30 Hz interval at 200 Hz: about 6 or 7.
  auto frame = reader->frame(1);
  ASSERT_TRUE(frame.ok());
  EXPECT_GE(frame->imu.size(), 4u);
  EXPECT_LE(frame->imu.size(), 10u);
}

}  // namespace
}  // namespace imufusion
