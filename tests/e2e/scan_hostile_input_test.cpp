// The tools against hostile input: bytes that are not UTF-8 in paths, image names and UDP
// datagrams; IMU samples no sensor gives (rates, forces, a jump in time) in imu.txt and over
// UDP; an imu.txt that covers no frame; a FIFO or a device where a file belongs; intrinsics no
// camera has. Each ends in a clear message or a scan that goes on, never in an abort or a hang.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scan_test_fixtures.hpp"
#include "udp_replay.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;
using test::read_json;
using test::read_text;

const fs::path kTools = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools";
// A hang is a failure, not a stuck test: each tool run gets this many seconds.
const std::string kDeadline = "timeout 120 ";

fs::path synthesize(const fs::path& root, const std::string& name, int frames, std::uint64_t seed) {
  return test::synthesize_small(root, name, synth::SceneKind::kRoom, frames, seed);
}

// Rewrites each data line of `file` through `edit(index, line)`.
template <typename Edit>
void edit_lines(const fs::path& file, Edit edit) {
  std::istringstream in(read_text(file));
  std::string line, out;
  int index = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') line = edit(index++, line);
    out += line + "\n";
  }
  std::ofstream(file, std::ios::binary) << out;
}

class ScanHostileInput : public test::ScanToolTest {
 protected:
  ScanHostileInput() : ScanToolTest("imufusion_scan_hostile_") {}
  test::ToolRun tool(const std::string& name, const std::string& args) {
    return test::run_tool(kDeadline + (kTools / name).string(), args, scratch_.path());
  }
  test::ToolRun scan_within_deadline(const std::string& args) { return tool("imufusion-scan", args); }
};

TEST_F(ScanHostileInput, PathsThatAreNotUtf8AreReportedNotFatal) {
  const fs::path seq = synthesize(scratch_.path(), "room\xff", 6, 41);
  const auto scanned = scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_NE(summary["input"].get<std::string>().find("room"), std::string::npos);
  EXPECT_EQ(summary["frames"], 6);

  const auto info = tool("imufusion-info", seq.string() + " --json");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["scannable"], true);

  const auto fused = tool("imufusion-fuse", seq.string() + " --out " + path("fused").string() + " --quiet");
  ASSERT_EQ(fused.exit_code, 0) << fused.err;
  EXPECT_EQ(read_json(path("fused") / "summary.json")["frames_fused"], 6);
}

TEST_F(ScanHostileInput, ADepthImageNamedInBytesThatAreNotUtf8IsReportedNotFatal) {
  const fs::path seq = synthesize(scratch_.path(), "room", 6, 43);
  // The 4th frame's image renamed depth/\xff.png, and truncated: the scan stops there.
  edit_lines(seq / "depth.txt", [&](int i, const std::string& line) {
    if (i != 3) return line;
    const std::string name = line.substr(line.find(' ') + 1);
    fs::rename(seq / name, seq / "depth" / "\xff.png");
    fs::resize_file(seq / "depth" / "\xff.png", 100);
    return line.substr(0, line.find(' ')) + " depth/\xff.png";
  });
  const auto scanned = scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  EXPECT_EQ(scanned.exit_code, 1) << scanned.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_NE(summary["stopped_early"].get<std::string>().find(".png"), std::string::npos);

  const auto info = tool("imufusion-info", seq.string() + " --json");
  EXPECT_EQ(info.exit_code, 1) << info.err;
  const auto report = nlohmann::json::parse(info.out);
  EXPECT_EQ(report["scannable"], false);
  EXPECT_FALSE(report["problems"].empty());
}

TEST_F(ScanHostileInput, ADatagramThatIsNotUtf8IsCountedAndTheScanGoesOn) {
  const fs::path seq = synthesize(scratch_.path(), "room", 15, 45);
  const std::uint16_t port = test::free_udp_port();
  std::vector<std::pair<double, std::string>> datagrams;
  for (int i = 0; i < 100; ++i) datagrams.emplace_back(0.02 * i, "\xff");
  test::UdpReplay sender(port, path("tool_stderr.txt"), datagrams);
  const auto run = scan(seq.string() + " --realtime --imu-udp " + std::to_string(port) + " --out " +
                        path("out").string());
  sender.stop();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_GT(sender.sent(), 0u) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_GE(summary["imu_stream"]["malformed"].get<int>(), 1);
  EXPECT_EQ(summary["frames"], 15);
}

}  // namespace
}  // namespace imufusion
