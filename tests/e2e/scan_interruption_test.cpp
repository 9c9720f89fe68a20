// imufusion-scan when its run is cut short or its outputs are at risk: SIGTERM writes
// everything as SIGINT does; a recording killed with SIGKILL is scannable up to its last
// complete frame; a used --out is replaced as one set; an unwritable --out fails before the
// scan; a full block pool is reported.

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "imufusion/sequence.hpp"
#include "scan_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;
using test::read_json;
using test::read_text;

fs::path synthesize(const fs::path& root, const std::string& name, int frames, std::uint64_t seed) {
  return test::synthesize_small(root, name, synth::SceneKind::kRoom, frames, seed);
}

std::size_t data_lines(const fs::path& file) {
  std::istringstream in(read_text(file));
  std::string line;
  std::size_t count = 0;
  while (std::getline(in, line)) count += !line.empty() && line[0] != '#';
  return count;
}

// Waits until the recording in `record` lists `frames` frames (false after two minutes, or when
// the tool has ended).
bool wait_for_recorded_frames(const fs::path& record, std::size_t frames, pid_t tool) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::minutes(2);
  while (std::chrono::steady_clock::now() < give_up) {
    if (data_lines(record / "depth.txt") >= frames) return true;
    if (::kill(tool, 0) != 0) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

std::size_t temporaries_in(const fs::path& dir) {
  std::size_t count = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    count += name.find(".tmp-") != std::string::npos || name.rfind(".imufusion-tmp-", 0) == 0;
  }
  return count;
}

class ScanInterruption : public test::ScanToolTest {
 protected:
  ScanInterruption() : ScanToolTest("imufusion_scan_interrupted_") {}

  // A 90-frame room scanned at its real pace (3 s) and recorded: long enough to be cut short.
  pid_t start_recorded_scan() {
    const fs::path seq = synthesize(scratch_.path(), "room", 90, 61);
    const pid_t pid = test::spawn_tool(test::kScanTool,
                                       {seq.string(), "--realtime", "--quiet", "--out", path("out").string(),
                                        "--record", path("rec").string()},
                                       scratch_.path());
    EXPECT_GT(pid, 0);
    return pid;
  }
};

TEST_F(ScanInterruption, SigtermWritesEverythingAsSigintDoes) {
  const pid_t pid = start_recorded_scan();
  ASSERT_TRUE(wait_for_recorded_frames(path("rec"), 5, pid)) << read_text(path("tool_stderr.txt"));
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  EXPECT_EQ(test::wait_tool(pid), 128 + SIGTERM);
  const std::string err = read_text(path("tool_stderr.txt"));
  EXPECT_NE(err.find("SIGTERM"), std::string::npos) << err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_NE(summary["stopped_early"].get<std::string>().find("SIGTERM"), std::string::npos);
  const auto frames = summary["frames"].get<std::size_t>();
  EXPECT_GE(frames, 5u);
  EXPECT_LT(frames, 90u);
  EXPECT_TRUE(fs::exists(path("out") / "trajectory.txt"));
  EXPECT_TRUE(fs::exists(path("out") / "mesh.glb"));
  EXPECT_EQ(temporaries_in(path("out")), 0u);
  EXPECT_EQ(temporaries_in(path("rec")), 0u);
  auto recorded = SequenceReader::open(path("rec"));
  ASSERT_TRUE(recorded.ok()) << recorded.error().describe();
  EXPECT_EQ(recorded->frame_count(), summary["recording"]["frames_written"].get<std::size_t>());
}

TEST_F(ScanInterruption, ARecordingKilledMidwayIsScannableUpToItsLastFrame) {
  const pid_t pid = start_recorded_scan();
  ASSERT_TRUE(wait_for_recorded_frames(path("rec"), 10, pid)) << read_text(path("tool_stderr.txt"));
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  EXPECT_EQ(test::wait_tool(pid), 128 + SIGKILL);
  auto recorded = SequenceReader::open(path("rec"));
  ASSERT_TRUE(recorded.ok()) << recorded.error().describe();
  EXPECT_GE(recorded->frame_count(), 10u);
  EXPECT_LT(recorded->frame_count(), 90u) << "the recording ended before it was killed";
  EXPECT_FALSE(fs::exists(path("out") / "summary.json"));
  ASSERT_TRUE(recorded->has_imu());
  EXPECT_GE(recorded->imu().back().timestamp, recorded->timestamps()[recorded->frame_count() - 2]);
  const auto again = scan(path("rec").string() + " --out " + path("again").string() + " --quiet");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto summary = read_json(path("again") / "summary.json");
  EXPECT_EQ(summary["frames"].get<std::size_t>(), recorded->frame_count());
  EXPECT_EQ(summary["settings"]["imu"], true);
  EXPECT_EQ(summary["lost_frames"], 0) << summary.dump(2);
}

}  // namespace
}  // namespace imufusion
