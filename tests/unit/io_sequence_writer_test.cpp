#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>

#include "imufusion/sequence.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;

StampedPose make_pose(double timestamp, double angle) {
  StampedPose pose;
  pose.timestamp = timestamp;
  pose.T_world_camera.linear() =
      Eigen::AngleAxisd(angle, Eigen::Vector3d(0.2, -1, 0.5).normalized()).toRotationMatrix();
  pose.T_world_camera.translation() = Eigen::Vector3d(angle, 1.0 / 3.0, -angle * 0.7);
  return pose;
}

TEST(SequenceWriter, RoundTripThroughReader) {
  TempDir dir;
  const auto seq = dir / "seq";
  auto writer = SequenceWriter::create(seq);
  ASSERT_TRUE(writer.ok()) << writer.error().describe();
  std::vector<DepthImage> depths;
  std::vector<ColorImage> colors;
  std::vector<ImuSample> imu;
  Trajectory truth;
  // Stamps that 6 decimals cannot hold (1/30 s), to check that the index keeps them exactly.
  for (int i = 0; i < 4; ++i) {
    const double t = 10.0 + i / 30.0;
    depths.push_back(testing::make_depth(97, 61, 100 + i, 1000.0));
    colors.push_back(testing::make_color(97, 61, 200 + i));
    ASSERT_TRUE(writer->add_depth(t, depths.back()).ok());
    ASSERT_TRUE(writer->add_color(t + 0.004, colors.back()).ok());
    truth.push_back(make_pose(t, 0.1 * i));
    ASSERT_TRUE(writer->add_ground_truth(truth.back()).ok());
  }
  for (int k = 0; k < 30; ++k) {
    ImuSample sample;
    sample.timestamp = 9.95 + k / 200.0;
    sample.gyro = Eigen::Vector3d(0.1 * k, -1.0 / 7.0, 3e-5);
    sample.accel = Eigen::Vector3d(0.0, 9.80665, -k / 3.0);
    imu.push_back(sample);
    ASSERT_TRUE(writer->add_imu(sample).ok());
  }
  ASSERT_TRUE(writer->set_intrinsics(Intrinsics{525.0, 524.5, 48.25, 30.75, 0, 0}).ok());
  Eigen::Isometry3d T_camera_imu = Eigen::Isometry3d::Identity();
  T_camera_imu.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_camera_imu.translation() = Eigen::Vector3d(0.01, -0.02, 0.005);
  ASSERT_TRUE(writer->set_T_camera_imu(T_camera_imu).ok());
  ASSERT_TRUE(writer->set_info("scene", "two boxes on a table").ok());
  ASSERT_TRUE(writer->set_info("depth_scale", "1000").ok());  // agrees with the images
  ASSERT_TRUE(writer->finish().ok());

  auto reader = SequenceReader::open(seq);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_EQ(reader->frame_count(), 4u);
  EXPECT_EQ(reader->info().info.at("scene"), "two boxes on a table");
  EXPECT_EQ(reader->info().depth_scale, 1000.0);
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, 525.0);
  EXPECT_EQ(reader->intrinsics()->cy, 30.75);
  EXPECT_EQ(reader->intrinsics()->width, 97);
  EXPECT_TRUE(reader->T_camera_imu().isApprox(T_camera_imu, 1e-12));
  ASSERT_EQ(reader->ground_truth().size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(reader->ground_truth()[i].timestamp, truth[i].timestamp);
    EXPECT_TRUE(reader->ground_truth()[i].T_world_camera.isApprox(truth[i].T_world_camera, 1e-12));
  }
  ASSERT_EQ(reader->imu().size(), imu.size());
  for (std::size_t k = 0; k < imu.size(); ++k) {
    EXPECT_EQ(reader->imu()[k].timestamp, imu[k].timestamp);
    EXPECT_EQ(reader->imu()[k].gyro, imu[k].gyro);
    EXPECT_EQ(reader->imu()[k].accel, imu[k].accel);
  }
  std::size_t imu_seen = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    auto frame = reader->next();
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    EXPECT_EQ(frame->timestamp, 10.0 + static_cast<double>(i) / 30.0);
    EXPECT_EQ(frame->depth.data, depths[i].data);
    ASSERT_TRUE(frame->color.has_value());
    EXPECT_EQ(frame->color->data, colors[i].data);
    imu_seen += frame->imu.size();
  }
  // Samples after the last depth stamp belong to no frame.
  std::size_t after_last = 0;
  for (const ImuSample& sample : imu) after_last += sample.timestamp > 10.1 ? 1 : 0;
  EXPECT_EQ(imu_seen + after_last, imu.size());
}

TEST(SequenceWriter, LensDistortionRoundTrips) {
  TempDir dir;
  auto writer = SequenceWriter::create(dir / "seq");
  ASSERT_TRUE(writer.ok()) << writer.error().describe();
  const Intrinsics k{525.0, 524.5, 48.25, 30.75, 0, 0, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}};
  ASSERT_TRUE(writer->set_intrinsics(k).ok());
  ASSERT_TRUE(writer->add_depth(0.0, testing::make_depth(97, 61, 100, 1000.0)).ok());
  ASSERT_TRUE(writer->finish().ok());
  auto reader = SequenceReader::open(dir / "seq");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->intrinsics()->distortion, k.distortion);
  Intrinsics bad = k;
  bad.distortion[2] = std::numeric_limits<double>::quiet_NaN();
  auto refused = SequenceWriter::create(dir / "other");
  ASSERT_TRUE(refused.ok());
  EXPECT_FALSE(refused->set_intrinsics(bad).ok());
}

TEST(SequenceWriter, RefusesNonEmptyDirectoryUnlessAllowed) {
  TempDir dir;
  testing::write_text(dir / "old.txt", "x");
  auto writer = SequenceWriter::create(dir.path());
  ASSERT_FALSE(writer.ok());
  EXPECT_EQ(writer.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(writer.error().message.find(dir.path().string()), std::string::npos);
  SequenceWriter::Options options;
  options.allow_existing = true;
  EXPECT_TRUE(SequenceWriter::create(dir.path(), options).ok());
}

TEST(SequenceWriter, RejectsBadInput) {
  TempDir dir;
  auto writer = SequenceWriter::create(dir / "seq");
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE(writer->add_depth(1.0, testing::make_depth(8, 6, 1)).ok());
  EXPECT_EQ(writer->add_depth(1.0, testing::make_depth(8, 6, 2)).error().code,
            ErrorCode::kInvalidArgument);  // duplicate stamp
  EXPECT_FALSE(writer->add_depth(0.5, testing::make_depth(8, 6, 2)).ok());
  EXPECT_FALSE(writer->add_depth(1.0000001, testing::make_depth(8, 6, 2)).ok());    // same name
  EXPECT_FALSE(writer->add_depth(2.0, testing::make_depth(8, 5, 2)).ok());          // size changed
  EXPECT_FALSE(writer->add_depth(2.0, testing::make_depth(8, 6, 2, 1000.0)).ok());  // scale
  EXPECT_FALSE(writer->add_color(1.0, testing::make_color(7, 6, 1)).ok());
  EXPECT_FALSE(writer->add_depth(std::nan(""), testing::make_depth(8, 6, 2)).ok());
  ImuSample sample;
  sample.timestamp = 1.0;
  ASSERT_TRUE(writer->add_imu(sample).ok());
  EXPECT_FALSE(writer->add_imu(sample).ok());
  sample.timestamp = 2.0;
  sample.gyro.x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(writer->add_imu(sample).ok());
  EXPECT_FALSE(writer->set_intrinsics(Intrinsics{0, 1, 1, 1, 0, 0}).ok());
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 2.0;
  EXPECT_FALSE(writer->set_T_camera_imu(scaled).ok());
  EXPECT_FALSE(writer->set_info("two words", "x").ok());
  EXPECT_FALSE(writer->set_info("key", "line\nbreak").ok());
  ASSERT_TRUE(writer->set_info("width", "9").ok());
  auto finished = writer->finish();
  ASSERT_FALSE(finished.ok());  // width 9 disagrees with the 8-pixel images
  EXPECT_NE(finished.error().message.find("width"), std::string::npos);
}

TEST(SequenceWriter, FinishNeedsADepthFrame) {
  TempDir dir;
  auto writer = SequenceWriter::create(dir / "seq");
  ASSERT_TRUE(writer.ok());
  EXPECT_FALSE(writer->finish().ok());
  EXPECT_FALSE(std::filesystem::exists(dir / "seq" / "depth.txt"));
}

TEST(SequenceWriter, MinimalSequenceHasOnlyDepthAndInfo) {
  TempDir dir;
  auto writer = SequenceWriter::create(dir / "seq");
  ASSERT_TRUE(writer.ok());
  ASSERT_TRUE(writer->add_depth(0.0, testing::make_depth(5, 4, 1)).ok());
  ASSERT_TRUE(writer->finish().ok());
  for (const char* absent :
       {"rgb.txt", "imu.txt", "groundtruth.txt", "calibration.txt", "imu_to_camera.txt"}) {
    EXPECT_FALSE(std::filesystem::exists(dir / "seq" / absent)) << absent;
  }
  auto reader = SequenceReader::open(dir / "seq");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->frame_count(), 1u);
  EXPECT_FALSE(reader->intrinsics().has_value());
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir / "seq")) {
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace imufusion
