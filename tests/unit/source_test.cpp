#include <gtest/gtest.h>

#include <random>

#include "imufusion/sequence.hpp"
#include "imufusion/source.hpp"
#include "imufusion/synth.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;

TEST(DepthMode, Parses) {
  auto mode = parse_depth_mode("320x240@60");
  ASSERT_TRUE(mode.ok()) << mode.error().describe();
  EXPECT_EQ(mode->width, 320);
  EXPECT_EQ(mode->height, 240);
  EXPECT_EQ(mode->fps, 60);
  const DepthMode defaults;
  EXPECT_EQ(defaults.width, 640);
  EXPECT_EQ(defaults.height, 480);
  EXPECT_EQ(defaults.fps, 30);
}

TEST(DepthMode, RefusesMalformedText) {
  for (const char* text : {"", "640x480", "640@30", "640x480@", "x480@30", "640x480@30fps",
                           "640x-480@30", "0x480@30", "640x480@0", "30@640x480", "a x b @ c"}) {
    const auto mode = parse_depth_mode(text);
    ASSERT_FALSE(mode.ok()) << text;
    EXPECT_EQ(mode.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(mode.error().message.find(std::string("'") + text + "'"), std::string::npos)
        << mode.error().message;
  }
}

TEST(FrameSource, ReadsASequenceDirectory) {
  TempDir dir;
  synth::SynthConfig config;
  config.width = 64;
  config.height = 48;
  config.frames = 4;
  const auto summary = synth::synthesize(config, dir / "seq");
  ASSERT_TRUE(summary.ok()) << summary.error().describe();
  auto reader = SequenceReader::open(dir / "seq");
  ASSERT_TRUE(reader.ok());

  for (const bool realtime : {false, true}) {
    SourceOptions options;
    options.realtime = realtime;
    auto source = open_frame_source((dir / "seq").string(), options);
    ASSERT_TRUE(source.ok()) << source.error().describe();
    FrameSource& s = **source;
    EXPECT_FALSE(s.live());
    EXPECT_EQ(s.intrinsics().width, 64);
    EXPECT_EQ(s.intrinsics().height, 48);
    EXPECT_EQ(s.intrinsics().fx, reader->intrinsics()->fx);
    ASSERT_TRUE(s.T_camera_imu().has_value());
    EXPECT_TRUE(s.T_camera_imu()->isApprox(reader->T_camera_imu()));
    EXPECT_NE(s.description().find("seq"), std::string::npos);
    for (std::size_t i = 0; i < reader->frame_count(); ++i) {
      auto frame = s.next();
      ASSERT_TRUE(frame.ok()) << frame.error().describe();
      ASSERT_TRUE(frame->has_value());
      const auto expected = reader->frame(i);
      EXPECT_EQ((*frame)->timestamp, expected->timestamp);
      EXPECT_EQ((*frame)->depth.data, expected->depth.data);
      EXPECT_TRUE((*frame)->color.has_value());
      EXPECT_EQ((*frame)->imu.size(), expected->imu.size());
    }
    for (int repeat = 0; repeat < 2; ++repeat) {
      auto end = s.next();
      ASSERT_TRUE(end.ok());
      EXPECT_FALSE(end->has_value());
    }
  }
  SourceOptions depth_only;
  depth_only.color = false;
  auto source = open_frame_source((dir / "seq").string(), depth_only);
  ASSERT_TRUE(source.ok());
  auto frame = (*source)->next();
  ASSERT_TRUE(frame.ok() && frame->has_value());
  EXPECT_FALSE((*frame)->color.has_value());
}

TEST(FrameSource, MissingInputsAreNamed) {
  TempDir dir;
  const auto missing = (dir / "nothing_here").string();
  auto source = open_frame_source(missing);
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kNotFound);
  EXPECT_NE(source.error().message.find("nothing_here"), std::string::npos);

  source = open_frame_source((dir / "scan.ONI").string());
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kNotFound);
  EXPECT_NE(source.error().message.find("scan.ONI"), std::string::npos);

  source = open_frame_source("realsense://0");
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(source.error().message.find("realsense://0"), std::string::npos);
}

TEST(FrameSource, CorruptAndEmptyRecordingsFailCleanly) {
  TempDir dir;
  std::vector<char> garbage(100000);
  std::mt19937 rng(5);
  for (char& c : garbage) c = static_cast<char>(rng());
  testing::write_bytes(dir / "garbage.oni", garbage);
  testing::write_text(dir / "empty.oni", "");
  // An .oni header followed by nothing: the first bytes of a real recording.
  testing::write_text(dir / "truncated.oni", std::string("NI10\x01\x00\x00\x00", 8));
  for (const char* name : {"garbage.oni", "empty.oni", "truncated.oni"}) {
    auto source = open_frame_source((dir / name).string());
    if (source.ok()) {
      // A file OpenNI2 accepts must still end in an error or the end, never a crash or hang.
      auto frame = (*source)->next();
      EXPECT_TRUE(!frame.ok() || !frame->has_value()) << name;
      continue;
    }
    if (!openni2_available()) {
      EXPECT_EQ(source.error().code, ErrorCode::kUnsupported) << name;
    } else {
      EXPECT_EQ(source.error().code, ErrorCode::kParseError) << source.error().describe();
    }
    EXPECT_NE(source.error().message.find(name), std::string::npos) << source.error().message;
  }
}

TEST(FrameSource, NoCameraIsAClearError) {
  auto source = open_frame_source("openni2://");
  if (source.ok()) GTEST_SKIP() << "a camera is connected: " << (*source)->description();
  EXPECT_EQ(source.error().code,
            openni2_available() ? ErrorCode::kNoDevice : ErrorCode::kUnsupported)
      << source.error().describe();
  EXPECT_NE(source.error().message.find("openni2://"), std::string::npos);

  source = open_frame_source("openni2://no-such-device/9@9");
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code,
            openni2_available() ? ErrorCode::kNoDevice : ErrorCode::kUnsupported)
      << source.error().describe();
  EXPECT_NE(source.error().message.find("no-such-device/9@9"), std::string::npos);
}

}  // namespace
}  // namespace imufusion
