#include <gtest/gtest.h>

#include <cmath>

#include "imufusion/trajectory.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;

Error read_error(const TempDir& dir, const std::string& content) {
  testing::write_text(dir / "groundtruth.txt", content);
  auto read = read_trajectory(dir / "groundtruth.txt");
  EXPECT_FALSE(read.ok());
  return read.ok() ? Error{} : read.error();
}

void expect_parse_error_at(const Error& error, const TempDir& dir, int line,
                           const std::string& fragment) {
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  const std::string prefix = (dir / "groundtruth.txt").string() + ":" + std::to_string(line) + ":";
  EXPECT_NE(error.message.find(prefix), std::string::npos) << error.message;
  EXPECT_NE(error.message.find(fragment), std::string::npos) << error.message;
}

TEST(Trajectory, RoundTrip) {
  TempDir dir;
  Trajectory written;
  for (int i = 0; i < 5; ++i) {
    StampedPose pose;
    pose.timestamp = 1305031102.160407 + 0.033 * i;
    pose.T_world_camera.linear() =
        Eigen::AngleAxisd(0.3 * i - 0.5, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    pose.T_world_camera.translation() = Eigen::Vector3d(0.1 * i, -2.5, 1.25 + i);
    written.push_back(pose);
  }
  ASSERT_TRUE(write_trajectory(dir / "t.txt", written, "estimated\nby a test").ok());
  auto read = read_trajectory(dir / "t.txt");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  ASSERT_EQ(read->size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_NEAR((*read)[i].timestamp, written[i].timestamp, 1e-6);
    EXPECT_TRUE((*read)[i].T_world_camera.isApprox(written[i].T_world_camera, 1e-8)) << i;
  }
}

TEST(Trajectory, FormatsTumLine) {
  StampedPose pose;
  pose.timestamp = 12.5;
  pose.T_world_camera.translation() = Eigen::Vector3d(1, 2, 3);
  EXPECT_EQ(format_tum_line(pose),
            "12.500000 1.000000000 2.000000000 3.000000000 0.000000000 0.000000000 0.000000000 "
            "1.000000000");
}

TEST(Trajectory, SkipsCommentsBlankLinesAndCarriageReturns) {
  TempDir dir;
  testing::write_text(
      dir / "groundtruth.txt",
      "# ground truth\r\n\r\n1.0 1 2 3 0 0 0 1\r\n  \n# more\n2.0\t4 5 6 0 0 1 0\n");
  auto read = read_trajectory(dir / "groundtruth.txt");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  ASSERT_EQ(read->size(), 2u);
  EXPECT_EQ((*read)[1].timestamp, 2.0);
  EXPECT_TRUE((*read)[1].T_world_camera.translation().isApprox(Eigen::Vector3d(4, 5, 6)));
  // qz = 1: a half turn about z.
  EXPECT_NEAR((*read)[1].T_world_camera.linear()(0, 0), -1.0, 1e-12);
}

TEST(Trajectory, NormalizesQuaternionsRoundedInTheFile) {
  TempDir dir;
  testing::write_text(dir / "groundtruth.txt", "1.0 0 0 0 0.6610 0.5868 -0.2994 -0.3594\n");
  auto read = read_trajectory(dir / "groundtruth.txt");
  ASSERT_TRUE(read.ok()) << read.error().describe();
  const Eigen::Matrix3d r = (*read)[0].T_world_camera.linear();
  EXPECT_TRUE((r * r.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
}

TEST(Trajectory, MissingFileIsNotFound) {
  TempDir dir;
  auto read = read_trajectory(dir / "absent.txt");
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, ErrorCode::kNotFound);
  EXPECT_NE(read.error().message.find((dir / "absent.txt").string()), std::string::npos);
}

TEST(Trajectory, WrongFieldCountNamesLine) {
  TempDir dir;
  expect_parse_error_at(read_error(dir, "# c\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n"), dir, 3,
                        "expected 8 fields");
}

TEST(Trajectory, NonNumberNamesValue) {
  TempDir dir;
  expect_parse_error_at(read_error(dir, "1.0 0 0 0 0 0 0 1\n2.0 0 abc 0 0 0 0 1\n"), dir, 2,
                        "ty 'abc' is not a number");
}

TEST(Trajectory, NanAndInfAreRejected) {
  TempDir dir;
  expect_parse_error_at(read_error(dir, "1.0 nan 0 0 0 0 0 1\n"), dir, 1, "'nan' is not finite");
  expect_parse_error_at(read_error(dir, "1.0 0 0 0 0 0 0 1\n2.0 0 0 -inf 0 0 0 1\n"), dir, 2,
                        "'-inf' is not finite");
  expect_parse_error_at(read_error(dir, "inf 0 0 0 0 0 0 1\n"), dir, 1, "timestamp 'inf'");
}

TEST(Trajectory, NonMonotonicTimestampIsRejected) {
  TempDir dir;
  expect_parse_error_at(read_error(dir, "2.0 0 0 0 0 0 0 1\n1.5 0 0 0 0 0 0 1\n"), dir, 2,
                        "timestamp 1.5 is not after");
}

TEST(Trajectory, DuplicateTimestampIsRejected) {
  TempDir dir;
  expect_parse_error_at(
      read_error(dir, "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n"), dir, 3,
      "duplicate");
}

TEST(Trajectory, NonUnitQuaternionIsRejected) {
  TempDir dir;
  expect_parse_error_at(read_error(dir, "1.0 0 0 0 0 0 0 2\n"), dir, 1, "norm");
  expect_parse_error_at(read_error(dir, "1.0 0 0 0 0 0 0 0\n"), dir, 1, "norm");
}

TEST(Trajectory, WriteRejectsNonFinitePose) {
  TempDir dir;
  StampedPose pose;
  pose.T_world_camera.translation().x() = std::nan("");
  auto status = write_trajectory(dir / "t.txt", {pose});
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kInvalidArgument);
  EXPECT_FALSE(std::filesystem::exists(dir / "t.txt"));
}

TEST(Trajectory, WriteIntoMissingDirectoryFails) {
  TempDir dir;
  auto status = write_trajectory(dir / "missing" / "t.txt", {StampedPose{}});
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::kIoError);
  EXPECT_NE(status.error().message.find((dir / "missing" / "t.txt").string()), std::string::npos);
}

}  // namespace
}  // namespace imufusion
