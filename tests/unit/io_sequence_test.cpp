#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>

#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"
#include "io/sequence_index.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;
using testing::write_text;

constexpr int kWidth = 9, kHeight = 7, kFrames = 5;
constexpr double kT0 = 100.0, kFramePeriod = 0.1, kImuPeriod = 0.025;

std::string fixed(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", value);
  return buffer;
}

// A valid sequence written file by file (independently of SequenceWriter): 5 depth frames at
// 10 Hz, colour 15 ms after each depth frame except the last (none within 20 ms), IMU at 40 Hz
// from 0.1 s before the first frame (some stamps equal depth stamps), ground truth, calibration,
// imu_to_camera and info.
class SequenceFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(dir / "depth");
    std::filesystem::create_directories(dir / "rgb");
    std::string depth = "# depth maps\n# timestamp filename\n", rgb = "# colour\n";
    for (int i = 0; i < kFrames; ++i) {
      const double t = kT0 + kFramePeriod * i;
      const std::string name = "depth/" + fixed(t) + ".png";
      ASSERT_TRUE(write_depth_png(dir / name, testing::make_depth(kWidth, kHeight, 10 + i)).ok());
      depth += fixed(t) + " " + name + "\n";
      const double tc = t + (i == kFrames - 1 ? 0.05 : 0.015);
      const std::string color_name = "rgb/" + fixed(tc) + ".png";
      ASSERT_TRUE(write_color_png(dir / color_name, testing::make_color(kWidth, kHeight, i)).ok());
      rgb += fixed(tc) + " " + color_name + "\n";
    }
    write_text(dir / "depth.txt", depth);
    write_text(dir / "rgb.txt", rgb);
    std::string imu = "# timestamp wx wy wz ax ay az\n";
    for (int k = 0; kT0 - 0.1 + kImuPeriod * k <= kT0 + kFramePeriod * (kFrames - 1) + 1e-9; ++k) {
      const double t = kT0 - 0.1 + kImuPeriod * k;
      imu += fixed(t) + " 0.1 0.2 " + std::to_string(k) + " 0 9.81 0\n";
    }
    write_text(dir / "imu.txt", imu);
    write_text(dir / "accelerometer.txt", "# ax ay az\n99.9 0 9.8 0\n100.2 0 9.8 0.1\n");
    write_text(dir / "groundtruth.txt",
               "# gt\n99.95 0 0 0 0 0 0 1\n100.2 0.1 0 0 0 0 0 1\n100.5 0.2 0 0 0 0 0 1\n");
    write_text(dir / "calibration.txt", "5.5 5.6 4.1 3.2\n");
    write_text(dir / "imu_to_camera.txt", "# qx qy qz qw tx ty tz\n1 0 0 0 0.01 0.02 0.03\n");
    write_text(dir / "info.txt", "depth_scale 1000\nwidth 9\nheight 7\nscene a small test\n");
  }

  Error open_error(const SequenceOptions& options = {}) {
    auto reader = SequenceReader::open(dir.path(), options);
    EXPECT_FALSE(reader.ok());
    return reader.ok() ? Error{} : reader.error();
  }

  // The error names `file` (relative to the sequence) and, when `line` > 0, its line.
  void expect_names(const Error& error, const std::string& file, int line = 0) {
    std::string expected = (dir / file).string();
    if (line > 0) expected += ":" + std::to_string(line) + ":";
    EXPECT_NE(error.message.find(expected), std::string::npos)
        << "expected '" << expected << "' in: " << error.message;
  }

  TempDir dir;
};

TEST_F(SequenceFixture, OpensAndReportsMetadata) {
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->frame_count(), 5u);
  const std::vector<double> stamps = reader->timestamps();
  ASSERT_EQ(stamps.size(), 5u);
  EXPECT_DOUBLE_EQ(stamps[3], 100.3);
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, 5.5);
  EXPECT_EQ(reader->intrinsics()->cy, 3.2);
  EXPECT_EQ(reader->intrinsics()->width, kWidth);
  EXPECT_EQ(reader->intrinsics()->height, kHeight);
  const SequenceInfo& info = reader->info();
  EXPECT_EQ(info.depth_scale, 1000.0);
  EXPECT_EQ(info.info.at("scene"), "a small test");
  EXPECT_TRUE(info.has_imu_to_camera);
  // qx = 1: a half turn about x.
  EXPECT_TRUE(reader->T_camera_imu().linear().isApprox(
      Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()));
  EXPECT_TRUE(reader->T_camera_imu().translation().isApprox(Eigen::Vector3d(0.01, 0.02, 0.03)));
  EXPECT_TRUE(reader->has_ground_truth());
  EXPECT_EQ(reader->ground_truth().size(), 3u);
  EXPECT_TRUE(reader->has_imu());
  EXPECT_EQ(info.accelerometer.size(), 2u);
  EXPECT_EQ(info.color_of_depth, (std::vector<int>{0, 1, 2, 3, -1}));
}

TEST_F(SequenceFixture, FramesCarryImagesColourAndTheirImuSamples) {
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  std::size_t imu_total = 0;
  double previous = -1e300;
  for (std::size_t i = 0; i < reader->frame_count(); ++i) {
    auto frame = reader->next();
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    EXPECT_EQ(frame->index, i);
    EXPECT_EQ(frame->depth.data, testing::make_depth(kWidth, kHeight, 10 + int(i)).data);
    EXPECT_EQ(frame->depth.depth_scale, 1000.0);
    if (i + 1 < reader->frame_count()) {
      ASSERT_TRUE(frame->color.has_value());
      EXPECT_EQ(frame->color->data, testing::make_color(kWidth, kHeight, int(i)).data);
      EXPECT_NEAR(frame->color_timestamp - frame->timestamp, 0.015, 1e-9);
    } else {
      EXPECT_FALSE(frame->color.has_value()) << "the last colour frame is 50 ms away";
    }
    ASSERT_FALSE(frame->imu.empty());
    for (const ImuSample& sample : frame->imu) {
      EXPECT_GT(sample.timestamp, previous);
      EXPECT_LE(sample.timestamp, frame->timestamp);
    }
    // The sample stamped exactly at the depth stamp belongs to this frame (interval (prev, t]).
    EXPECT_DOUBLE_EQ(frame->imu.back().timestamp, frame->timestamp);
    imu_total += frame->imu.size();
    previous = frame->timestamp;
  }
  EXPECT_EQ(imu_total, reader->imu().size());
  EXPECT_TRUE(reader->done());
  auto past_end = reader->next();
  ASSERT_FALSE(past_end.ok());
  EXPECT_EQ(past_end.error().code, ErrorCode::kInvalidArgument);
  reader->seek(2);
  auto again = reader->next();
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->index, 2u);
}

TEST_F(SequenceFixture, FirstFrameLookbackLimitsItsImuSamples) {
  SequenceOptions options;
  options.first_frame_imu_lookback = 0.03;
  auto reader = SequenceReader::open(dir.path(), options);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  auto frame = reader->frame(0);
  ASSERT_TRUE(frame.ok());
  // Stamps 99.975 and 100.0 lie in (99.97, 100.0].
  ASSERT_EQ(frame->imu.size(), 2u);
  EXPECT_DOUBLE_EQ(frame->imu.front().timestamp, 99.975);
}

TEST_F(SequenceFixture, ColourCanBeSkippedOrMatchedMoreTightly) {
  SequenceOptions options;
  options.load_color = false;
  auto reader = SequenceReader::open(dir.path(), options);
  ASSERT_TRUE(reader.ok());
  EXPECT_FALSE(reader->frame(0)->color.has_value());
  options.load_color = true;
  options.max_color_time_difference = 0.01;
  reader = SequenceReader::open(dir.path(), options);
  ASSERT_TRUE(reader.ok());
  EXPECT_EQ(reader->info().color_of_depth, std::vector<int>(5, -1));
}

TEST(Association, IsOneToOneClosestFirst) {
  // Depth 1.00 and 1.01 both lie within 20 ms of colour 1.012; the closer (1.01) gets it.
  const std::vector<int> match = io::associate_streams({1.0, 1.01, 2.0}, {1.012, 1.995, 3.0}, 0.02);
  EXPECT_EQ(match, (std::vector<int>{-1, 0, 1}));
  EXPECT_EQ(io::associate_streams({1.0}, {}, 0.02), std::vector<int>{-1});
}

TEST_F(SequenceFixture, MissingCalibrationNeedsCallerIntrinsics) {
  std::filesystem::remove(dir / "calibration.txt");
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  EXPECT_FALSE(reader->intrinsics().has_value());
  SequenceOptions options;
  options.intrinsics = Intrinsics{7, 7, 4, 3, 0, 0};
  reader = SequenceReader::open(dir.path(), options);
  ASSERT_TRUE(reader.ok());
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, 7.0);
  EXPECT_EQ(reader->intrinsics()->width, kWidth);
  options.intrinsics = Intrinsics{7, -7, 4, 3, 0, 0};
  EXPECT_EQ(open_error(options).code, ErrorCode::kInvalidArgument);
}

TEST_F(SequenceFixture, OptionalFilesMayBeAbsent) {
  for (const char* name : {"rgb.txt", "imu.txt", "accelerometer.txt", "groundtruth.txt",
                           "imu_to_camera.txt", "info.txt"}) {
    std::filesystem::remove(dir / name);
  }
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_FALSE(reader->has_imu());
  EXPECT_FALSE(reader->has_ground_truth());
  EXPECT_TRUE(reader->T_camera_imu().isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(reader->info().depth_scale, 5000.0);
  EXPECT_EQ(reader->info().width, kWidth);  // from the first PNG's header
  auto frame = reader->frame(4);
  ASSERT_TRUE(frame.ok());
  EXPECT_FALSE(frame->color.has_value());
  EXPECT_TRUE(frame->imu.empty());
}

TEST(SequenceReader, MissingDirectory) {
  TempDir dir;
  auto reader = SequenceReader::open(dir / "absent");
  ASSERT_FALSE(reader.ok());
  EXPECT_EQ(reader.error().code, ErrorCode::kNotFound);
  EXPECT_NE(reader.error().message.find((dir / "absent").string()), std::string::npos);
}

TEST_F(SequenceFixture, MissingDepthIndex) {
  std::filesystem::remove(dir / "depth.txt");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kNotFound);
  expect_names(error, "depth.txt");
}

TEST_F(SequenceFixture, EmptyDepthIndex) {
  write_text(dir / "depth.txt", "# nothing\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "depth.txt");
}

TEST_F(SequenceFixture, MissingDepthImage) {
  std::filesystem::remove(dir / ("depth/" + fixed(100.2) + ".png"));
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kNotFound);
  expect_names(error, "depth.txt", 5);
  expect_names(error, "depth/" + fixed(100.2) + ".png");
}

TEST_F(SequenceFixture, MissingColourImage) {
  std::filesystem::remove(dir / ("rgb/" + fixed(100.115) + ".png"));
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kNotFound);
  expect_names(error, "rgb.txt", 3);
}

TEST_F(SequenceFixture, MalformedIndexLine) {
  write_text(dir / "depth.txt", "100.0 depth/" + fixed(100.0) + ".png extra\n");
  Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "depth.txt", 1);
  EXPECT_NE(error.message.find("expected 2 fields"), std::string::npos);

  write_text(dir / "depth.txt", "# c\n10o.0 depth/" + fixed(100.0) + ".png\n");
  error = open_error();
  expect_names(error, "depth.txt", 2);
  EXPECT_NE(error.message.find("'10o.0' is not a number"), std::string::npos) << error.message;
}

TEST_F(SequenceFixture, NonMonotonicDepthStamps) {
  write_text(dir / "depth.txt",
             "100.1 depth/" + fixed(100.1) + ".png\n100.0 depth/" + fixed(100.0) + ".png\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "depth.txt", 2);
  EXPECT_NE(error.message.find("not after"), std::string::npos);
}

TEST_F(SequenceFixture, DuplicateColourStamps) {
  const std::string line = "100.015 rgb/" + fixed(100.015) + ".png\n";
  write_text(dir / "rgb.txt", line + line);
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "rgb.txt", 2);
  EXPECT_NE(error.message.find("duplicate"), std::string::npos);
}

TEST_F(SequenceFixture, NonMonotonicImuStamps) {
  write_text(dir / "imu.txt", "100.0 0 0 0 0 0 0\n100.1 0 0 0 0 0 0\n100.05 0 0 0 0 0 0\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "imu.txt", 3);
}

TEST_F(SequenceFixture, DuplicateGroundTruthStamps) {
  write_text(dir / "groundtruth.txt", "100.0 0 0 0 0 0 0 1\n100.0 0 0 0 0 0 0 1\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "groundtruth.txt", 2);
}

TEST_F(SequenceFixture, NonMonotonicAccelerometerStamps) {
  write_text(dir / "accelerometer.txt", "100.2 0 0 0\n100.1 0 0 0\n");
  const Error error = open_error();
  expect_names(error, "accelerometer.txt", 2);
}

TEST_F(SequenceFixture, NanAndInfAreRejectedEverywhere) {
  struct Case {
    const char* file;
    std::string content;
    int line;
  };
  const Case cases[] = {
      {"imu.txt", "100.0 0 nan 0 0 0 0\n", 1},
      {"accelerometer.txt", "# a\n100.0 0 0 inf\n", 2},
      {"calibration.txt", "5 5 NaN 3\n", 1},
      {"imu_to_camera.txt", "0 0 0 1 inf 0 0\n", 1},
      {"groundtruth.txt", "100.0 0 0 0 0 0 0 1\n100.1 -inf 0 0 0 0 0 1\n", 2},
      {"info.txt", "depth_scale inf\n", 1},
      {"rgb.txt", "nan rgb/x.png\n", 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string saved = std::string(testing::read_bytes(dir / c.file).data(),
                                          testing::read_bytes(dir / c.file).size());
    write_text(dir / c.file, c.content);
    const Error error = open_error();
    EXPECT_EQ(error.code, ErrorCode::kParseError);
    expect_names(error, c.file, c.line);
    EXPECT_NE(error.message.find("not finite"), std::string::npos) << error.message;
    write_text(dir / c.file, saved);
  }
}

TEST_F(SequenceFixture, MalformedImuLine) {
  write_text(dir / "imu.txt", "100.0 0 0 0 0 0\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "imu.txt", 1);
  EXPECT_NE(error.message.find("expected 7 fields"), std::string::npos);
}

TEST_F(SequenceFixture, BadQuaternionInImuToCamera) {
  write_text(dir / "imu_to_camera.txt", "0.5 0 0 0.5 0 0 0\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "imu_to_camera.txt", 1);
  EXPECT_NE(error.message.find("norm"), std::string::npos);
}

TEST_F(SequenceFixture, NonPositiveIntrinsics) {
  write_text(dir / "calibration.txt", "5.5 0 4.1 3.2\n");
  Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "calibration.txt", 1);
  EXPECT_NE(error.message.find("fy 0 must be positive"), std::string::npos) << error.message;
  write_text(dir / "calibration.txt", "-5.5 5 4.1 3.2\n");
  expect_names(open_error(), "calibration.txt", 1);
  write_text(dir / "calibration.txt", "5.5 5 4.1\n");
  expect_names(open_error(), "calibration.txt", 1);
}

TEST_F(SequenceFixture, CalibrationWithLensDistortion) {
  write_text(dir / "calibration.txt", "5.5 5.6 4.1 3.2 0.26 -0.95 -0.005 0.0026 1.16\n");
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, 5.5);
  const std::array<double, 5> want = {0.26, -0.95, -0.005, 0.0026, 1.16};
  EXPECT_EQ(reader->intrinsics()->distortion, want);
  // Four numbers: a pinhole; any count but 4 and 9 is refused, naming the fields expected.
  write_text(dir / "calibration.txt", "5.5 5.6 4.1 3.2\n");
  auto pinhole = SequenceReader::open(dir.path());
  ASSERT_TRUE(pinhole.ok());
  EXPECT_FALSE(pinhole->intrinsics()->distorted());
  write_text(dir / "calibration.txt", "5.5 5.6 4.1 3.2 0.26\n");
  const Error error = open_error();
  expect_names(error, "calibration.txt", 1);
  EXPECT_NE(error.message.find("k3"), std::string::npos) << error.message;
  write_text(dir / "calibration.txt", "5.5 5.6 4.1 3.2 0.26 -0.95 nan 0.0026 1.16\n");
  expect_names(open_error(), "calibration.txt", 1);
}

TEST_F(SequenceFixture, InfoSizeDisagreeingWithImages) {
  write_text(dir / "info.txt", "width 10\nheight 7\n");
  const Error error = open_error();
  EXPECT_EQ(error.code, ErrorCode::kParseError);
  expect_names(error, "depth/" + fixed(100.0) + ".png");
  EXPECT_NE(error.message.find("info.txt"), std::string::npos);
}

TEST_F(SequenceFixture, BadInfoValues) {
  write_text(dir / "info.txt", "depth_scale -3\n");
  expect_names(open_error(), "info.txt", 1);
  write_text(dir / "info.txt", "scene a\nwidth nine\n");
  expect_names(open_error(), "info.txt", 2);
  write_text(dir / "info.txt", "scene a\nscene b\n");
  expect_names(open_error(), "info.txt", 2);
}

TEST_F(SequenceFixture, CountsFurtherProblems) {
  write_text(dir / "imu.txt", "x 0 0 0 0 0 0\n");
  write_text(dir / "calibration.txt", "0 0 0 0\n");
  const Error error = open_error();
  EXPECT_NE(error.message.find("and 1 more problem"), std::string::npos) << error.message;
  const io::SequenceIndex index = io::load_sequence_index(dir.path(), {});
  ASSERT_EQ(index.problems.size(), 2u);
}

TEST_F(SequenceFixture, TruncatedDepthImageFailsInNextAndReadingGoesOn) {
  const auto path = dir / ("depth/" + fixed(100.2) + ".png");
  std::vector<char> bytes = testing::read_bytes(path);
  bytes.resize(bytes.size() / 2);
  testing::write_bytes(path, bytes);
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_TRUE(reader->next().ok());
  ASSERT_TRUE(reader->next().ok());
  auto bad = reader->next();
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kParseError);
  expect_names(bad.error(), "depth/" + fixed(100.2) + ".png");
  auto after = reader->next();
  ASSERT_TRUE(after.ok()) << after.error().describe();
  EXPECT_EQ(after->index, 3u);
}

TEST_F(SequenceFixture, NonPngDepthFileFailsInNext) {
  write_text(dir / ("depth/" + fixed(100.1) + ".png"), "not a png");
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  auto bad = reader->frame(1);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kParseError);
  expect_names(bad.error(), "depth/" + fixed(100.1) + ".png");
}

TEST_F(SequenceFixture, EightBitDepthImageFailsInNext) {
  const std::vector<std::uint8_t> pixels(kWidth * kHeight, 3);
  testing::write_png_independently(dir / ("depth/" + fixed(100.3) + ".png"), kWidth, kHeight, 8, 0,
                                   pixels);
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  auto bad = reader->frame(3);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(bad.error().message.find("wrong bit depth"), std::string::npos);
  expect_names(bad.error(), "depth/" + fixed(100.3) + ".png");
}

TEST_F(SequenceFixture, DepthSizeDifferentFromFirstFrameFailsInNext) {
  std::filesystem::remove(dir / "info.txt");
  ASSERT_TRUE(
      write_depth_png(dir / ("depth/" + fixed(100.4) + ".png"), testing::make_depth(8, 7, 1)).ok());
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  auto bad = reader->frame(4);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kParseError);
  EXPECT_NE(bad.error().message.find("8x7"), std::string::npos);
  expect_names(bad.error(), "depth/" + fixed(100.4) + ".png");
}

TEST_F(SequenceFixture, ColourSizeDifferentFromDepthFailsInNext) {
  const std::string name = "rgb/" + fixed(100.015) + ".png";
  ASSERT_TRUE(write_color_png(dir / name, testing::make_color(kWidth + 1, kHeight, 0)).ok());
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  auto bad = reader->frame(0);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kParseError);
  expect_names(bad.error(), name);
  EXPECT_TRUE(reader->frame(1).ok());
}

TEST_F(SequenceFixture, FrameIndexOutOfRange) {
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok());
  EXPECT_EQ(reader->frame(5).error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace imufusion
