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
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "imufusion/image_io.hpp"
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
                                       {seq.string(), "--realtime", "--quiet", "--out",
                                        path("out").string(), "--record", path("rec").string()},
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

// A sequence whose depth images hold no measurement: a scan of it fuses nothing.
fs::path synthesize_empty(const fs::path& root) {
  const fs::path seq = synthesize(root, "empty", 3, 63);
  std::istringstream index(read_text(seq / "depth.txt"));
  std::string line;
  while (std::getline(index, line)) {
    if (line.empty() || line[0] == '#') continue;
    const fs::path image = seq / line.substr(line.find(' ') + 1);
    auto depth = read_depth_png(image, 5000.0);
    EXPECT_TRUE(depth.ok());
    std::fill(depth->data.begin(), depth->data.end(), std::uint16_t{0});
    EXPECT_TRUE(write_depth_png(image, *depth).ok());
  }
  return seq;
}

TEST_F(ScanInterruption, AUsedOutIsReplacedAsOneSet) {
  const fs::path room = synthesize(scratch_.path(), "room", 6, 65);
  ASSERT_EQ(scan(room.string() + " --out " + path("out").string() + " --quiet").exit_code, 0);
  ASSERT_TRUE(fs::exists(path("out") / "mesh.glb"));
  const auto run = scan(synthesize_empty(scratch_.path()).string() + " --out " +
                        path("out").string() + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_EQ(summary["mesh_triangles"], 0);
  for (const char* stale : {"mesh.glb", "mesh.ply", "preview.png", "overview.png"}) {
    EXPECT_FALSE(fs::exists(path("out") / stale)) << stale << " of the earlier run is still there";
  }
  EXPECT_EQ(data_lines(path("out") / "trajectory.txt"), 3u);
  EXPECT_EQ(temporaries_in(path("out")), 0u);
}

TEST_F(ScanInterruption, AnUnwritableOutFailsBeforeTheScan) {
  const fs::path room = synthesize(scratch_.path(), "room", 4, 67);
  fs::create_directories(path("locked"));
  fs::permissions(path("locked"), fs::perms::owner_read | fs::perms::owner_exec);
  // Permissions do not stop root: make the directory immutable instead.
  std::ofstream probe(path("locked") / "probe");
  const bool root = probe.good();
  probe.close();
  fs::remove(path("locked") / "probe");
  if (root) {
    ASSERT_EQ(std::system(("chattr +i " + path("locked").string()).c_str()), 0)
        << "chattr is needed as root";
  }
  const auto run = scan(room.string() + " --out " + path("locked").string() + " --record " +
                        path("rec").string() + " --quiet");
  if (root) {
    EXPECT_EQ(std::system(("chattr -i " + path("locked").string()).c_str()), 0);
  }
  fs::permissions(path("locked"), fs::perms::owner_all);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("cannot write into the output directory " + path("locked").string()),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(fs::exists(path("rec"))) << "the scan ran before --out was found unwritable";
}

// The pool starts below its capacity, grows to it, and then reports as one that started there.
TEST_F(ScanInterruption, AFullBlockPoolIsReported) {
  const fs::path room = synthesize(scratch_.path(), "room", 8, 69);
  const auto run = scan(room.string() + " --out " + path("out").string() +
                        " --block-capacity 200 --initial-blocks 50 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("block pool"), std::string::npos) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_GT(summary["pool_full_frames"].get<int>(), 0);
  EXPECT_TRUE(summary.contains("first_pool_full_frame"));
  const std::string csv = read_text(path("out") / "frames.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_NE(header.find(",pool_full,"), std::string::npos) << header;
  EXPECT_EQ(summary["blocks_allocated"], 200);
  EXPECT_EQ(summary["pool_blocks_reserved"], 200);
  EXPECT_GT(summary["pool_growths"].get<int>(), 0);
  // The default pool holds the room: nothing is refused.
  const auto roomy = scan(room.string() + " --out " + path("roomy").string() + " --quiet");
  ASSERT_EQ(roomy.exit_code, 0) << roomy.err;
  const auto roomy_summary = read_json(path("roomy") / "summary.json");
  EXPECT_EQ(roomy_summary["pool_full_frames"], 0);
  EXPECT_GE(roomy_summary["pool_blocks_reserved"].get<int>(),
            roomy_summary["blocks_allocated"].get<int>());
  EXPECT_EQ(roomy.err.find("block pool"), std::string::npos) << roomy.err;
}

}  // namespace
}  // namespace imufusion
