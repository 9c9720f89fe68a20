#include "imufusion/source.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>

#include "../support/oni_writer.hpp"
#include "imufusion/imu_stream.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "io/frame_pacer.hpp"
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

// A recording of `frames` random depth (and colour) frames, 30 Hz with jitter, starting at an
// arbitrary device time; colour stamped a little after its depth frame, as cameras do.
test::OniRecording random_recording(int width, int height, int frames, bool color,
                                    std::uint32_t seed) {
  std::mt19937 rng(seed);
  test::OniRecording recording;
  recording.width = width;
  recording.height = height;
  recording.horizontal_fov = 1.0226;  // a Kinect v1's, radians
  recording.vertical_fov = 0.7966;
  std::uniform_int_distribution<int> depth_mm(0, 9000), jitter_us(-500, 500), byte(0, 255);
  std::uint64_t t = 123456789;
  for (int i = 0; i < frames; ++i) {
    t += 33333 + jitter_us(rng);
    std::vector<std::uint16_t> depth(static_cast<std::size_t>(width) * height);
    for (auto& d : depth) d = static_cast<std::uint16_t>(depth_mm(rng) < 500 ? 0 : depth_mm(rng));
    recording.depth.push_back({t, test::oni_depth_bytes(depth)});
    if (color) {
      std::vector<std::uint8_t> rgb(depth.size() * 3);
      for (auto& c : rgb) c = static_cast<std::uint8_t>(byte(rng));
      recording.color.push_back({t + 200 + static_cast<std::uint64_t>(jitter_us(rng) + 500), rgb});
    }
  }
  return recording;
}

std::vector<std::uint16_t> depth_of(const test::OniFrame& frame) {
  std::vector<std::uint16_t> depth(frame.pixels.size() / 2);
  for (std::size_t i = 0; i < depth.size(); ++i) {
    depth[i] = static_cast<std::uint16_t>(frame.pixels[2 * i] | (frame.pixels[2 * i + 1] << 8));
  }
  return depth;
}

// Reads `source` to its end and checks every frame against `recording`: order, timestamps
// (device microseconds as seconds), size, depth bit for bit, colour when asked for.
void expect_plays_back(FrameSource& source, const test::OniRecording& recording, bool color) {
  for (std::size_t i = 0; i < recording.depth.size(); ++i) {
    auto frame = source.next();
    ASSERT_TRUE(frame.ok()) << "frame " << i << ": " << frame.error().describe();
    ASSERT_TRUE(frame->has_value()) << "the recording ended after " << i << " frames";
    const Frame& f = **frame;
    EXPECT_EQ(f.index, i);
    EXPECT_DOUBLE_EQ(f.timestamp, static_cast<double>(recording.depth[i].timestamp_us) * 1e-6);
    ASSERT_EQ(f.depth.width, recording.width);
    ASSERT_EQ(f.depth.height, recording.height);
    EXPECT_EQ(f.depth.depth_scale, 1000.0);
    EXPECT_EQ(f.depth.data, depth_of(recording.depth[i])) << "depth of frame " << i;
    ASSERT_EQ(f.color.has_value(), color) << i;
    if (color) {
      // The colour frame recorded with this depth frame (stamped just after it).
      EXPECT_EQ(f.color->data, recording.color[i].pixels) << "colour of frame " << i;
      EXPECT_DOUBLE_EQ(f.color_timestamp,
                       static_cast<double>(recording.color[i].timestamp_us) * 1e-6);
    }
  }
  for (int repeat = 0; repeat < 2; ++repeat) {
    auto end = source.next();
    ASSERT_TRUE(end.ok()) << end.error().describe();
    EXPECT_FALSE(end->has_value());
  }
}

TEST(OniPlayback, DeliversEveryFrameInOrderWithItsTimestampAndDepth) {
  TempDir dir;
  for (const bool color : {false, true}) {
    const test::OniRecording recording = random_recording(48, 36, 12, color, color ? 7 : 3);
    const auto path = (dir / (color ? "depth_color.oni" : "depth.oni")).string();
    ASSERT_TRUE(test::write_oni(path, recording).ok());
    auto source = open_frame_source(path);
    if (!openni2_available()) {
      ASSERT_FALSE(source.ok());
      EXPECT_EQ(source.error().code, ErrorCode::kUnsupported);
      continue;
    }
    ASSERT_TRUE(source.ok()) << source.error().describe();
    FrameSource& s = **source;
    EXPECT_FALSE(s.live());
    EXPECT_EQ(s.description(), path);
    const Intrinsics& k = s.intrinsics();
    EXPECT_EQ(k.width, 48);
    EXPECT_EQ(k.height, 36);
    // The recorded fields of view (stored as float by OpenNI2) and the image centre.
    EXPECT_NEAR(k.fx, 24.0 / std::tan(0.5 * recording.horizontal_fov), 1e-4);
    EXPECT_NEAR(k.fy, 18.0 / std::tan(0.5 * recording.vertical_fov), 1e-4);
    EXPECT_EQ(k.cx, 23.5);
    EXPECT_EQ(k.cy, 17.5);
    expect_plays_back(s, recording, color);
  }
}

// Colour left out; and --realtime, which paces the same frames (FramePacer below) and drops
// none however slowly they are taken.
TEST(OniPlayback, HonoursTheColourAndRealtimeOptions) {
  if (!openni2_available()) GTEST_SKIP() << "built without OpenNI2";
  TempDir dir;
  const test::OniRecording recording = random_recording(32, 24, 8, true, 11);
  ASSERT_TRUE(test::write_oni(dir / "scan.oni", recording).ok());
  for (const bool realtime : {false, true}) {
    SourceOptions options;
    options.color = realtime;
    options.realtime = realtime;
    auto source = open_frame_source((dir / "scan.oni").string(), options);
    ASSERT_TRUE(source.ok()) << source.error().describe();
    expect_plays_back(**source, recording, options.color);
  }
}

TEST(OniPlayback, GivenIntrinsicsReplaceTheFieldOfView) {
  if (!openni2_available()) GTEST_SKIP() << "built without OpenNI2";
  TempDir dir;
  const test::OniRecording recording = random_recording(32, 24, 3, false, 23);
  ASSERT_TRUE(test::write_oni(dir / "scan.oni", recording).ok());
  SourceOptions options;
  options.intrinsics = Intrinsics{};
  options.intrinsics->fx = 41.5;
  options.intrinsics->fy = 40.25;
  options.intrinsics->cx = 16.125;
  options.intrinsics->cy = 11.75;
  auto source = open_frame_source((dir / "scan.oni").string(), options);
  ASSERT_TRUE(source.ok()) << source.error().describe();
  const Intrinsics& k = (*source)->intrinsics();
  const Intrinsics& given = *options.intrinsics;
  EXPECT_TRUE(k.fx == given.fx && k.fy == given.fy && k.cx == given.cx && k.cy == given.cy)
      << k.fx << " " << k.fy << " " << k.cx << " " << k.cy;
  EXPECT_EQ(k.width, 32);  // the stream's, not the (zero) size given
  EXPECT_EQ(k.height, 24);
  expect_plays_back(**source, recording, false);

  options.intrinsics->fy = 0.0;
  source = open_frame_source((dir / "scan.oni").string(), options);
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(source.error().message.find("scan.oni"), std::string::npos) << source.error().message;
}

// The byte offset where the `n`th (1-based) NEW_DATA record of an .oni file starts.
std::size_t new_data_record(const std::vector<char>& bytes, int n) {
  const std::string magic("NIR\0\x0A\0\0\0", 8);  // record magic, then type NEW_DATA
  const std::string text(bytes.begin(), bytes.end());
  std::size_t at = 0;
  for (int seen = 0; seen < n; ++seen) {
    at = text.find(magic, seen == 0 ? 0 : at + 1);
    if (at == std::string::npos) return at;
  }
  return at;
}

TEST(OniPlayback, ACutRecordingIsRefusedByName) {
  if (!openni2_available()) GTEST_SKIP() << "built without OpenNI2";
  TempDir dir;
  const test::OniRecording recording = random_recording(32, 24, 10, false, 17);
  ASSERT_TRUE(test::write_oni(dir / "full.oni", recording).ok());
  // A closed recording cut short has lost its seek tables: OpenNI2 refuses to open it.
  std::vector<char> bytes = testing::read_bytes(dir / "full.oni");
  const std::size_t seventh = new_data_record(bytes, 7);
  ASSERT_NE(seventh, std::string::npos);
  bytes.resize(seventh + 40 + recording.depth[6].pixels.size() / 2);
  testing::write_bytes(dir / "cut.oni", bytes);
  auto source = open_frame_source((dir / "cut.oni").string());
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kParseError);
  EXPECT_NE(source.error().message.find("cut.oni"), std::string::npos) << source.error().message;
}

TEST(OniPlayback, AnInterruptedRecordingPlaysItsCompleteFramesThenFails) {
  if (!openni2_available()) GTEST_SKIP() << "built without OpenNI2";
  TempDir dir;
  test::OniRecording recording = random_recording(32, 24, 10, false, 19);
  recording.finalized = false;  // the recorder never closed it: frame count unknown
  ASSERT_TRUE(test::write_oni(dir / "full.oni", recording).ok());
  std::vector<char> bytes = testing::read_bytes(dir / "full.oni");
  const std::size_t seventh = new_data_record(bytes, 7);
  ASSERT_NE(seventh, std::string::npos);
  bytes.resize(seventh + 40 + recording.depth[6].pixels.size() / 2);  // mid-way through frame 7
  testing::write_bytes(dir / "interrupted.oni", bytes);
  SourceOptions options;
  options.frame_timeout = 0.5;
  auto source = open_frame_source((dir / "interrupted.oni").string(), options);
  ASSERT_TRUE(source.ok()) << source.error().describe();
  for (std::size_t i = 0; i < 6; ++i) {
    auto frame = (*source)->next();
    ASSERT_TRUE(frame.ok()) << i << ": " << frame.error().describe();
    ASSERT_TRUE(frame->has_value()) << i;
    EXPECT_EQ((**frame).depth.data, depth_of(recording.depth[i])) << i;
  }
  auto end = (*source)->next();
  ASSERT_FALSE(end.ok());
  EXPECT_EQ(end.error().code, ErrorCode::kParseError);
  EXPECT_NE(end.error().message.find("interrupted.oni"), std::string::npos) << end.error().message;
  EXPECT_NE(end.error().message.find("after frame 6"), std::string::npos) << end.error().message;
}

// OpenNI2's DummyDevice driver (Debian: libopenni2-0) is a software camera at URI "Dummy":
// 320x240@30 depth (1 mm; a top row at 2000 mm and a small moving disc) and RGB888 colour. It
// reports no field of view and cannot change modes. Its streams do not stop their threads when
// destroyed (a thread may run on into the freed stream for up to 33 ms), so the camera opened
// here is left open until the process ends.
TEST(OpenNI2Camera, TheDummyDeviceStreamsLiveFramesOnTheHostClock) {
  SourceOptions options;
  options.depth_mode = DepthMode{320, 240, 30};
  auto source = open_frame_source("openni2://Dummy", options);
  if (!openni2_available()) {
    ASSERT_FALSE(source.ok());
    EXPECT_EQ(source.error().code, ErrorCode::kUnsupported);
    return;
  }
  if (!source.ok() && source.error().code == ErrorCode::kNoDevice) {
    GTEST_SKIP() << "OpenNI2's DummyDevice driver is not installed: " << source.error().message;
  }
  // No field of view: the intrinsics must be given.
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kUnsupported) << source.error().describe();
  EXPECT_NE(source.error().message.find("field of view"), std::string::npos);
  EXPECT_NE(source.error().message.find("openni2://Dummy"), std::string::npos);

  options.depth_mode = DepthMode{};  // 640x480@30, which it does not have
  options.intrinsics = Intrinsics{};
  options.intrinsics->fx = options.intrinsics->fy = 262.5;
  options.intrinsics->cx = 159.5;
  options.intrinsics->cy = 119.5;
  source = open_frame_source("openni2://Dummy", options);
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(source.error().message.find("320x240@30"), std::string::npos) << source.error().message;

  options.depth_mode = DepthMode{320, 240, 30};
  const double opened_at = host_clock_now();
  source = open_frame_source("openni2://Dummy", options);
  ASSERT_TRUE(source.ok()) << source.error().describe();
  FrameSource& camera = *source->release();  // left open, see above
  EXPECT_TRUE(camera.live());
  EXPECT_NE(camera.description().find("openni2://Dummy"), std::string::npos);
  EXPECT_EQ(camera.intrinsics().width, 320);
  EXPECT_EQ(camera.intrinsics().height, 240);
  EXPECT_EQ(camera.intrinsics().fx, 262.5);
  EXPECT_EQ(camera.intrinsics().cy, 119.5);
  double previous = -1.0;
  int with_color = 0;
  for (std::size_t i = 0; i < 10; ++i) {
    auto frame = camera.next();
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    ASSERT_TRUE(frame->has_value());
    const Frame& f = **frame;
    EXPECT_EQ(f.index, i);
    // Device stamps mapped onto the host clock: after the camera was opened, no later than
    // now, strictly increasing.
    EXPECT_GT(f.timestamp, opened_at);
    EXPECT_LE(f.timestamp, host_clock_now());
    EXPECT_GT(f.timestamp, previous);
    previous = f.timestamp;
    ASSERT_EQ(f.depth.width, 320);
    ASSERT_EQ(f.depth.height, 240);
    EXPECT_EQ(f.depth.depth_scale, 1000.0);
    for (int u = 0; u < 320; ++u) ASSERT_EQ(f.depth.at(u, 0), 2000) << u;
    if (f.color) {
      ++with_color;
      ASSERT_EQ(f.color->width, 320);
      ASSERT_EQ(f.color->height, 240);
      EXPECT_EQ(f.color->data[2], 255);  // the driver's marker: pixel 0 blue
      EXPECT_LE(f.color_timestamp, host_clock_now());
    }
  }
  // Its colour thread starts a frame interval after the depth thread, then keeps pace.
  EXPECT_GT(with_color, 0);
}

TEST(FramePacer, SchedulesFramesAtTheirRecordedIntervalsFromTheFirst) {
  using Clock = io::FramePacer::Clock;
  io::FramePacer pacer;
  const Clock::time_point start{std::chrono::seconds(50)};
  const auto ms = [](int n) { return std::chrono::milliseconds(n); };
  // The first frame is due when it arrives; each later one at its recorded offset from it.
  EXPECT_EQ(pacer.due(1000.0, start + ms(3)), start + ms(3));
  EXPECT_EQ(pacer.due(1000.5, start + ms(10)), start + ms(503));
  // A frame read late is due in the past (no wait), and does not move the schedule.
  EXPECT_EQ(pacer.due(1000.25, start + ms(900)), start + ms(253));
  EXPECT_EQ(pacer.due(1001.0, start + ms(901)), start + ms(1003));
}

}  // namespace
}  // namespace imufusion
