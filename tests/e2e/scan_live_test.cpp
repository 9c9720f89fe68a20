// Runs the built imufusion-scan with its live inputs on small synthetic sequences: --record writes
// a sequence that reads back frame for frame and scans the same; --imu-udp takes the IMU from a
// UDP stream replayed at its real rate while the frames come at theirs (--realtime); an OpenNI2
// recording (.oni) of a synthetic room scans with every frame tracked; an OpenNI2 input without
// a camera fails cleanly.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../support/oni_writer.hpp"
#include "imufusion/eval.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/source.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"
#include "scan_test_fixtures.hpp"
#include "udp_replay.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

using test::read_json;

// ATE RMSE bound (metres) of a 30-frame 160x120 room scanned from an .oni (depth in whole
// millimetres, no IMU): 0.8 to 3.4 mm over seeds 1-12, every frame tracked in each.
constexpr double kOniAteRmse = 0.01;

fs::path synthesize(const fs::path& root, const std::string& name, int frames, std::uint64_t seed) {
  return test::synthesize_small(root, name, synth::SceneKind::kRoom, frames, seed);
}

std::size_t tracked_frames(const nlohmann::json& summary) {
  return summary["frames"].get<std::size_t>() - summary["lost_frames"].get<std::size_t>() -
         summary["recovering_frames"].get<std::size_t>();
}

class ScanLive : public test::ScanToolTest {
 protected:
  ScanLive() : ScanToolTest("imufusion_scan_live_") {}
};

TEST_F(ScanLive, RecordsASequenceThatReadsBackAndScansTheSame) {
  const fs::path seq = synthesize(scratch_.path(), "room", 24, 5);
  const test::ToolRun run = scan(seq.string() + " --out " + path("out").string() + " --record " +
                                 path("rec").string() + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json summary = read_json(path("out") / "summary.json");
  ASSERT_TRUE(summary.contains("recording")) << summary.dump(2);
  EXPECT_EQ(summary["recording"]["frames_written"], 24);
  EXPECT_EQ(summary["recording"]["frames_dropped"], 0);
  EXPECT_GT(summary["recording"]["imu_samples"].get<std::size_t>(), 0u);
  EXPECT_FALSE(summary["recording"].contains("error"));

  auto original = SequenceReader::open(seq);
  auto recorded = SequenceReader::open(path("rec"));
  ASSERT_TRUE(original.ok()) << original.error().describe();
  ASSERT_TRUE(recorded.ok()) << recorded.error().describe();
  ASSERT_EQ(recorded->frame_count(), original->frame_count());
  std::size_t imu_handed_out = 0;  // the samples up to the last frame, those the scan took
  for (std::size_t i = 0; i < original->frame_count(); ++i) {
    auto a = original->frame(i);
    auto b = recorded->frame(i);
    ASSERT_TRUE(a.ok() && b.ok()) << i;
    EXPECT_EQ(a->depth.data, b->depth.data) << "depth of frame " << i;
    EXPECT_DOUBLE_EQ(a->timestamp, b->timestamp) << i;
    imu_handed_out += a->imu.size();
  }
  EXPECT_EQ(recorded->imu().size(), imu_handed_out);

  const test::ToolRun again =
      scan(path("rec").string() + " --out " + path("out2").string() + " --quiet");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const nlohmann::json summary2 = read_json(path("out2") / "summary.json");
  EXPECT_EQ(summary2["frames"], summary["frames"]);
  EXPECT_EQ(tracked_frames(summary2), tracked_frames(summary));
}

TEST_F(ScanLive, TakesTheImuFromAUdpStreamAtItsRealRate) {
  constexpr int kFrames = 30;
  const fs::path seq = synthesize(scratch_.path(), "room", kFrames, 9);
  auto reader = SequenceReader::open(seq);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  ASSERT_TRUE(reader->has_imu());
  auto first = reader->frame(0);
  ASSERT_TRUE(first.ok());
  const double t_first_frame = first->timestamp;
  std::vector<std::pair<double, std::string>> datagrams;
  for (const auto& [t, line] : test::imu_lines(seq / "imu.txt"))
    datagrams.emplace_back(t - t_first_frame, line + "\n");
  ASSERT_FALSE(datagrams.empty());

  // Replays imu.txt in real time once the tool listens (its stderr says so), the sample at the
  // first frame's timestamp sent as the first frame is read.
  const std::uint16_t port = test::free_udp_port();
  test::UdpReplay sender(port, path("tool_stderr.txt"), datagrams);
  const test::ToolRun run = scan(seq.string() + " --realtime --imu-udp " + std::to_string(port) +
                                 " --out " + path("out").string());
  sender.stop();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_GT(sender.sent(), 0u) << "the tool never said it was listening: " << run.err;

  const nlohmann::json summary = read_json(path("out") / "summary.json");
  ASSERT_TRUE(summary.contains("imu_stream")) << summary.dump(2);
  const auto& stream = summary["imu_stream"];
  EXPECT_GT(stream["samples"].get<std::size_t>(), 0u);
  EXPECT_LE(stream["samples"].get<std::size_t>(), sender.sent());
  EXPECT_EQ(stream["malformed"], 0);
  EXPECT_NE(stream["clock_offset_source"], "none");
  EXPECT_GE(stream["clock_offset_standard_error_s"].get<double>(), 0.0);
  EXPECT_TRUE(stream.contains("clock_offset_correlation_host_s"));
  // The stream starts as the first frame is read, both at their real rate, so the IMU clock maps
  // onto the frame clock with a small offset (the sender's start delay; the host clock itself is
  // far from both), whatever the machine's load does to the frame rate.
  EXPECT_LT(std::abs(stream["clock_offset_frame_s"].get<double>()), 0.5) << stream.dump(2);
  EXPECT_EQ(summary["settings"]["imu_source"], "udp");
  EXPECT_EQ(summary["frames"], kFrames);
  // Most frames track: the stream's samples, mapped onto the frame clock, seed the ICP as the
  // sequence's own would.
  EXPECT_GE(tracked_frames(summary), static_cast<std::size_t>(kFrames * 8 / 10)) << summary.dump(2);
}

// The sequence as an OpenNI2 recording: depth in millimetres (what OpenNI2 depth streams
// carry), its colour, device timestamps in microseconds, and the fields of view that give back
// the sequence's intrinsics (its principal point is the image centre, as OpenNI2 assumes).
test::OniRecording oni_of(const fs::path& seq) {
  auto reader = SequenceReader::open(seq);
  EXPECT_TRUE(reader.ok()) << reader.error().describe();
  const Intrinsics k = *reader->intrinsics();
  EXPECT_DOUBLE_EQ(k.cx, 0.5 * (k.width - 1));
  EXPECT_DOUBLE_EQ(k.cy, 0.5 * (k.height - 1));
  test::OniRecording oni;
  oni.width = k.width;
  oni.height = k.height;
  oni.horizontal_fov = 2.0 * std::atan(0.5 * k.width / k.fx);
  oni.vertical_fov = 2.0 * std::atan(0.5 * k.height / k.fy);
  const auto us = [](double seconds) {
    return static_cast<std::uint64_t>(std::llround(seconds * 1e6));
  };
  for (std::size_t i = 0; i < reader->frame_count(); ++i) {
    auto frame = reader->frame(i);
    EXPECT_TRUE(frame.ok()) << frame.error().describe();
    std::vector<std::uint16_t> mm(frame->depth.data.size());
    for (std::size_t p = 0; p < mm.size(); ++p) {
      mm[p] = static_cast<std::uint16_t>(
          std::lround(frame->depth.data[p] * 1000.0 / frame->depth.depth_scale));
    }
    oni.depth.push_back({us(frame->timestamp), test::oni_depth_bytes(mm)});
    if (frame->color) oni.color.push_back({us(frame->color_timestamp), frame->color->data});
  }
  return oni;
}

TEST_F(ScanLive, ScansAnOniRecordingOfASyntheticRoomWithEveryFrameTracked) {
  constexpr int kFrames = 30;
  const fs::path seq = synthesize(scratch_.path(), "room", kFrames, 23);
  const test::OniRecording oni = oni_of(seq);
  ASSERT_EQ(oni.depth.size(), static_cast<std::size_t>(kFrames));
  ASSERT_EQ(oni.color.size(), static_cast<std::size_t>(kFrames));
  const fs::path recording = path("room.oni");
  ASSERT_TRUE(test::write_oni(recording, oni).ok());
  if (!openni2_available()) {
    const test::ToolRun run = scan(recording.string() + " --out " + path("out").string());
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_NE(run.err.find("OpenNI2"), std::string::npos) << run.err;
    return;
  }
  // --realtime: frames at the recorded pace however slowly the scan takes them, none dropped.
  for (const char* flags : {"", " --realtime"}) {
    const fs::path out = path(*flags != 0 ? "out_realtime" : "out");
    const test::ToolRun run =
        scan(recording.string() + flags + " --out " + out.string() + " --quiet");
    ASSERT_EQ(run.exit_code, 0) << flags << ": " << run.err;
    for (const char* file :
         {"trajectory.txt", "frames.csv", "mesh.glb", "mesh.ply", "summary.json"}) {
      EXPECT_TRUE(fs::exists(out / file)) << file;
    }
    const nlohmann::json summary = read_json(out / "summary.json");
    EXPECT_EQ(summary["frames"], kFrames) << flags;
    EXPECT_EQ(tracked_frames(summary), static_cast<std::size_t>(kFrames))
        << flags << summary.dump(2);
    EXPECT_FALSE(summary.contains("stopped_early")) << summary.dump(2);
    EXPECT_GT(summary["mesh_triangles"].get<std::size_t>(), 0u);

    // One pose per recorded frame at its recorded time, close to the synthesizer's path.
    auto trajectory = read_trajectory(out / "trajectory.txt");
    ASSERT_TRUE(trajectory.ok()) << trajectory.error().describe();
    ASSERT_EQ(trajectory->size(), static_cast<std::size_t>(kFrames));
    for (std::size_t i = 0; i < trajectory->size(); ++i) {
      EXPECT_NEAR((*trajectory)[i].timestamp, static_cast<double>(oni.depth[i].timestamp_us) * 1e-6,
                  1e-6)
          << i;
    }
    auto reader = SequenceReader::open(seq);
    ASSERT_TRUE(reader.ok());
    auto ate = evaluate_ate(reader->ground_truth(), *trajectory);
    ASSERT_TRUE(ate.ok()) << ate.error().describe();
    EXPECT_EQ(ate->stats.count, static_cast<std::size_t>(kFrames));
    EXPECT_LT(ate->stats.rmse, kOniAteRmse) << flags;
  }
}

TEST_F(ScanLive, CameraInputWithoutACameraFailsCleanly) {
  const test::ToolRun run =
      scan("openni2:// --out " + path("out").string() + " --record " + path("rec").string());
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.err.find("error:"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("openni2"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(path("out")));
  EXPECT_FALSE(fs::exists(path("rec")));
}

}  // namespace
}  // namespace imufusion
