#include "imufusion/recorder.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

using testing::TempDir;

// A short synthetic live session: 12 frames at 30 Hz of 80x60 depth + colour rendered from the
// room, a 200 Hz IMU on a clock 2.5 s behind the host.
struct LiveSession {
  Intrinsics intrinsics = synth::default_intrinsics(80, 60);
  std::vector<Frame> frames;
  std::vector<ImuSample> imu;  // IMU clock
  double offset = 2.5;         // t_host = t_imu + offset
};

LiveSession make_session() {
  LiveSession session;
  const auto scene = synth::make_scene(synth::SceneKind::kRoom, 3);
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 3, 20.0);
  for (int i = 0; i < 12; ++i) {
    const double t = 20.0 + i / 30.0;
    auto rendered = synth::render_frame(scene, motion.pose_at(t), session.intrinsics,
                                        synth::SensorModel{}, 100 + i, true);
    Frame frame;
    frame.index = static_cast<std::size_t>(i);
    frame.timestamp = t;
    frame.depth = std::move(rendered.depth);
    frame.color = std::move(rendered.color);
    frame.color_timestamp = t + 0.001;
    session.frames.push_back(std::move(frame));
  }
  session.imu =
      synth::generate_imu(motion, synth::ImuConfig{}, synth::draw_imu_bias(3), 19.9, 20.4, 3);
  for (ImuSample& sample : session.imu) sample.timestamp -= session.offset;
  return session;
}

// The scanner's loop: the IMU that arrived since the last frame, then the frame. Returns the IMU
// samples pushed (those up to the last frame).
std::size_t push_session(SessionRecorder& recorder, const LiveSession& session) {
  std::size_t imu_pushed = 0;
  for (const Frame& frame : session.frames) {
    std::vector<ImuSample> batch;
    while (imu_pushed < session.imu.size() &&
           session.imu[imu_pushed].timestamp + session.offset <= frame.timestamp) {
      batch.push_back(session.imu[imu_pushed++]);
    }
    recorder.push_imu(batch);
    EXPECT_TRUE(recorder.push_frame(frame));
  }
  return imu_pushed;
}

TEST(SessionRecorder, RecordsASessionThatReadsBackBitExactly) {
  TempDir dir;
  const LiveSession session = make_session();
  auto recorder = SessionRecorder::create(dir / "live");
  ASSERT_TRUE(recorder.ok()) << recorder.error().describe();
  recorder->set_intrinsics(session.intrinsics);
  recorder->set_T_camera_imu(synth::default_T_camera_imu());
  recorder->set_info("source", "openni2://");
  recorder->set_imu_clock_offset(session.offset - 0.25);  // an early estimate...
  // The queue holds the whole session, so nothing is dropped.
  const std::size_t imu_pushed = push_session(*recorder, session);
  recorder->push_imu(
      {session.imu.begin() + static_cast<std::ptrdiff_t>(imu_pushed), session.imu.end()});
  recorder->push_imu({session.imu.front()});       // stale: dropped
  recorder->set_imu_clock_offset(session.offset);  // ...refined: the last one counts
  const Status finished = recorder->finish();
  ASSERT_TRUE(finished.ok()) << finished.error().describe();
  const RecorderStats stats = recorder->stats();
  EXPECT_EQ(stats.frames_written, session.frames.size());
  EXPECT_EQ(stats.frames_dropped, 0u);
  EXPECT_EQ(stats.imu_samples, session.imu.size());
  EXPECT_EQ(stats.imu_dropped, 1u);

  auto reader = SequenceReader::open(dir / "live");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_EQ(reader->frame_count(), session.frames.size());
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, session.intrinsics.fx);
  EXPECT_EQ(reader->intrinsics()->cy, session.intrinsics.cy);
  EXPECT_TRUE(reader->info().has_imu_to_camera);
  EXPECT_TRUE(reader->T_camera_imu().isApprox(synth::default_T_camera_imu(), 1e-12));
  EXPECT_EQ(reader->info().info.at("source"), "openni2://");
  EXPECT_EQ(std::stod(reader->info().info.at("imu_clock_offset")), session.offset);
  for (std::size_t i = 0; i < session.frames.size(); ++i) {
    auto frame = reader->frame(i);
    ASSERT_TRUE(frame.ok()) << frame.error().describe();
    EXPECT_EQ(frame->timestamp, session.frames[i].timestamp);
    EXPECT_EQ(frame->depth.data, session.frames[i].depth.data) << i;
    EXPECT_EQ(frame->depth.depth_scale, session.frames[i].depth.depth_scale);
    ASSERT_TRUE(frame->color.has_value());
    EXPECT_EQ(frame->color->data, session.frames[i].color->data) << i;
    EXPECT_EQ(frame->color_timestamp, session.frames[i].color_timestamp);
  }
  ASSERT_EQ(reader->imu().size(), session.imu.size());
  for (std::size_t i = 0; i < session.imu.size(); ++i) {
    EXPECT_EQ(reader->imu()[i].timestamp, session.imu[i].timestamp + session.offset);
    EXPECT_EQ(reader->imu()[i].gyro, session.imu[i].gyro);
    EXPECT_EQ(reader->imu()[i].accel, session.imu[i].accel);
  }
}

TEST(SessionRecorder, ABoundedQueueDropsInsteadOfBlocking) {
  TempDir dir;
  const LiveSession session = make_session();
  RecorderOptions options;
  options.max_queued_frames = 1;
  auto recorder = SessionRecorder::create(dir / "live", options);
  ASSERT_TRUE(recorder.ok()) << recorder.error().describe();
  recorder->set_intrinsics(session.intrinsics);
  std::size_t accepted = 0;
  for (const Frame& frame : session.frames) accepted += recorder->push_frame(frame) ? 1 : 0;
  ASSERT_TRUE(recorder->finish().ok());
  const RecorderStats stats = recorder->stats();
  EXPECT_GE(accepted, 1u);
  EXPECT_EQ(stats.frames_queued, accepted);
  EXPECT_EQ(stats.frames_written, accepted);
  EXPECT_EQ(stats.frames_queued + stats.frames_dropped, session.frames.size());
  auto reader = SequenceReader::open(dir / "live");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->frame_count(), accepted);
}

TEST(SessionRecorder, FinishSurfacesTheFirstWriteError) {
  TempDir dir;
  const LiveSession session = make_session();
  auto recorder = SessionRecorder::create(dir / "live");
  ASSERT_TRUE(recorder.ok());
  // depth/ replaced by a plain file of that name: no image can be written into it.
  std::filesystem::remove_all(dir / "live" / "depth");
  testing::write_text(dir / "live" / "depth", "in the way");
  recorder->push_frame(session.frames[0]);
  recorder->push_frame(session.frames[1]);
  const Status finished = recorder->finish();
  ASSERT_FALSE(finished.ok());
  EXPECT_NE(finished.error().message.find("depth"), std::string::npos) << finished.error().message;
  EXPECT_EQ(recorder->finish().error().message, finished.error().message);
  EXPECT_EQ(recorder->stats().frames_written, 0u);
  EXPECT_FALSE(recorder->push_frame(session.frames[2]));
}

// A recording that never reaches finish() (the process killed, the disk full) is a sequence up
// to its last complete frame: index lines, calibration, info (depth_scale) and the IMU are on
// disk as the frames go.
TEST(SessionRecorder, ARecordingThatNeverFinishesReadsBackUpToItsLastFrame) {
  TempDir dir;
  const LiveSession session = make_session();
  std::size_t imu_before_last_frame = 0;
  {
    auto recorder = SessionRecorder::create(dir / "live");
    ASSERT_TRUE(recorder.ok()) << recorder.error().describe();
    recorder->set_intrinsics(session.intrinsics);
    recorder->set_info("source", "openni2://");
    recorder->set_imu_clock_offset(session.offset);
    imu_before_last_frame = push_session(*recorder, session);
    // Gone without finish(): the worker drains its queue as the process would until killed.
  }
  auto reader = SequenceReader::open(dir / "live");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_EQ(reader->frame_count(), session.frames.size());
  ASSERT_TRUE(reader->intrinsics().has_value());
  EXPECT_EQ(reader->intrinsics()->fx, session.intrinsics.fx);
  EXPECT_EQ(reader->info().info.at("source"), "openni2://");
  auto last = reader->frame(session.frames.size() - 1);
  ASSERT_TRUE(last.ok()) << last.error().describe();
  EXPECT_EQ(last->depth.data, session.frames.back().depth.data);
  EXPECT_EQ(last->depth.depth_scale, session.frames.back().depth.depth_scale);
  ASSERT_EQ(reader->imu().size(), imu_before_last_frame);
  EXPECT_EQ(reader->imu().back().timestamp,
            session.imu[imu_before_last_frame - 1].timestamp + session.offset);
}

TEST(SessionRecorder, RefusesAnExistingNonEmptyDirectory) {
  TempDir dir;
  testing::write_text(dir / "live" / "something.txt", "x");
  const auto recorder = SessionRecorder::create(dir / "live");
  ASSERT_FALSE(recorder.ok());
}

TEST(SessionRecorder, RejectsTimestampsThatGoBack) {
  TempDir dir;
  const LiveSession session = make_session();
  auto recorder = SessionRecorder::create(dir / "live");
  ASSERT_TRUE(recorder.ok());
  recorder->push_frame(session.frames[1]);
  recorder->push_frame(session.frames[0]);
  const Status finished = recorder->finish();
  ASSERT_FALSE(finished.ok());
  EXPECT_NE(finished.error().message.find("not after"), std::string::npos);
}

}  // namespace
}  // namespace imufusion
