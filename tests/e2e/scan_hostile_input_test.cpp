// The tools against hostile input: bytes that are not UTF-8 in paths, image names and UDP
// datagrams; IMU samples no sensor gives (rates, forces, a jump in time) in imu.txt and over
// UDP; an imu.txt that covers no frame; a FIFO or a device where a file or an image belongs;
// intrinsics no camera has. Each ends in a clear message or a scan that goes on, never in an abort
// or a hang.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "imufusion/sequence.hpp"
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

std::string fixed(double seconds) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.9f", seconds);
  return buffer;
}

std::size_t tracked_frames(const nlohmann::json& summary) {
  return summary["frames"].get<std::size_t>() - summary["lost_frames"].get<std::size_t>() -
         summary["recovering_frames"].get<std::size_t>();
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

// imu.txt's line `index` with its gyro (fields 2-4) replaced.
void set_gyro(const fs::path& seq, int index, const std::string& gyro) {
  edit_lines(seq / "imu.txt", [&](int i, const std::string& line) {
    if (i != index) return line;
    std::istringstream fields(line);
    std::string t, wx, wy, wz, rest;
    fields >> t >> wx >> wy >> wz;
    std::getline(fields, rest);
    return t + " " + gyro + rest;
  });
}

class ScanHostileInput : public test::ScanToolTest {
 protected:
  ScanHostileInput() : ScanToolTest("imufusion_scan_hostile_") {}
  test::ToolRun tool(const std::string& name, const std::string& args) {
    return test::run_tool(kDeadline + (kTools / name).string(), args, scratch_.path());
  }
  test::ToolRun scan_within_deadline(const std::string& args) {
    return tool("imufusion-scan", args);
  }
};

TEST_F(ScanHostileInput, PathsThatAreNotUtf8AreReportedNotFatal) {
  const fs::path seq = synthesize(scratch_.path(), "room\xff", 6, 41);
  const auto scanned =
      scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  ASSERT_EQ(scanned.exit_code, 0) << scanned.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_NE(summary["input"].get<std::string>().find("room"), std::string::npos);
  EXPECT_EQ(summary["frames"], 6);

  const auto info = tool("imufusion-info", seq.string() + " --json");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["scannable"], true);

  const auto fused =
      tool("imufusion-fuse", seq.string() + " --out " + path("fused").string() + " --quiet");
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
  const auto scanned =
      scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
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

TEST_F(ScanHostileInput, ImuSamplesNoSensorGivesAreLeftOutAndCounted) {
  const fs::path seq = synthesize(scratch_.path(), "room", 20, 47);
  set_gyro(seq, 40, "1e300 0 0");  // not finite once integrated
  set_gyro(seq, 90, "0 1000 0");   // 160 turns a second
  const auto run =
      scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("2 samples beyond"), std::string::npos) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_EQ(summary["imu_rejected"]["implausible"], 2);
  EXPECT_EQ(summary["settings"]["imu"], true);
  EXPECT_EQ(summary["lost_frames"], 0) << summary.dump(2);
  ASSERT_TRUE(summary.contains("ate"));
  EXPECT_LT(summary["ate"]["rmse"].get<double>(), 0.015);

  const auto info = tool("imufusion-info", seq.string() + " --json");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["imu"]["implausible_samples"], 2);
}

TEST_F(ScanHostileInput, ImuThatCoversNoFrameFallsBackToTheSettingsWithout) {
  const fs::path seq = synthesize(scratch_.path(), "room", 8, 49);
  edit_lines(seq / "imu.txt", [](int, const std::string& line) {
    const std::size_t space = line.find(' ');
    return fixed(std::stod(line.substr(0, space)) + 1000.0) + line.substr(space);
  });
  const auto run =
      scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("covers none of the 8 frames"), std::string::npos) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  EXPECT_EQ(summary["settings"]["imu_in_sequence"], true);
  EXPECT_EQ(summary["settings"]["imu"], false);
  EXPECT_EQ(summary["settings"]["icp_iterations_cap"], 30);
  EXPECT_TRUE(summary["settings"].contains("imu_fallback"));

  const auto info = tool("imufusion-info", seq.string());
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("covers none of the depth frames"), std::string::npos) << info.out;
}

TEST_F(ScanHostileInput, ALineFarInTheFutureOverUdpDoesNotMoveTheClock) {
  constexpr int kFrames = 30;
  const fs::path seq = synthesize(scratch_.path(), "room", kFrames, 9);
  auto reader = SequenceReader::open(seq);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  const double t_first_frame = reader->timestamps().front();
  std::vector<std::pair<double, std::string>> datagrams;
  for (const auto& [t, line] : test::imu_lines(seq / "imu.txt")) {
    datagrams.emplace_back(t - t_first_frame, line + "\n");
    // One line a million seconds ahead of the stream, early in the scan.
    if (datagrams.size() == 60)
      datagrams.emplace_back(t - t_first_frame, fixed(t + 1e6) + " 0 0 0 0 9.81 0\n");
  }
  const std::uint16_t port = test::free_udp_port();
  test::UdpReplay sender(port, path("tool_stderr.txt"), datagrams);
  const auto run = scan(seq.string() + " --realtime --imu-udp " + std::to_string(port) + " --out " +
                        path("out").string());
  sender.stop();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto summary = read_json(path("out") / "summary.json");
  const auto& stream = summary["imu_stream"];
  EXPECT_EQ(stream["time_jumps"], 1) << stream.dump(2);
  EXPECT_LT(std::abs(stream["clock_offset_frame_s"].get<double>()), 0.5) << stream.dump(2);
  EXPECT_GE(tracked_frames(summary), static_cast<std::size_t>(kFrames * 8 / 10)) << summary.dump(2);
}

TEST_F(ScanHostileInput, AFifoOrADeviceWhereAFileBelongsIsRefusedPromptly) {
  const fs::path seq = synthesize(scratch_.path(), "room", 4, 51);
  fs::remove(seq / "groundtruth.txt");
  ASSERT_EQ(::mkfifo((seq / "groundtruth.txt").c_str(), 0600), 0);
  auto scanned = scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  EXPECT_EQ(scanned.exit_code, 1) << "124: it hung\n" << scanned.err;
  EXPECT_NE(scanned.err.find("groundtruth.txt: not a regular file"), std::string::npos)
      << scanned.err;
  auto info = tool("imufusion-info", seq.string());
  EXPECT_EQ(info.exit_code, 1) << info.err;
  EXPECT_NE(info.out.find("NOT scannable"), std::string::npos) << info.out;

  fs::remove(seq / "groundtruth.txt");
  fs::remove(seq / "imu.txt");
  fs::create_symlink("/dev/zero", seq / "imu.txt");
  scanned = scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  EXPECT_EQ(scanned.exit_code, 1) << scanned.err;
  EXPECT_NE(scanned.err.find("imu.txt: not a regular file"), std::string::npos) << scanned.err;
  info = tool("imufusion-info", seq.string());
  EXPECT_EQ(info.exit_code, 1) << info.err;
  EXPECT_NE(info.out.find("NOT scannable"), std::string::npos) << info.out;
}

TEST_F(ScanHostileInput, ADepthImageThatIsAFifoOrADeviceIsNamedAsOne) {
  const fs::path seq = synthesize(scratch_.path(), "room", 4, 55);
  std::string second;  // the second frame's PNG, as depth.txt names it
  edit_lines(seq / "depth.txt", [&](int i, const std::string& line) {
    if (i == 1) second = line.substr(line.find(' ') + 1);
    return line;
  });
  ASSERT_FALSE(second.empty());
  const fs::path image = seq / second;
  for (const bool fifo : {true, false}) {
    fs::remove(image);
    if (fifo) {
      ASSERT_EQ(::mkfifo(image.c_str(), 0600), 0);
    } else {
      fs::create_symlink("/dev/zero", image);
    }
    const std::string expected = image.string() + " is not a regular file";
    const auto info = tool("imufusion-info", seq.string());
    EXPECT_EQ(info.exit_code, 1) << info.err;
    EXPECT_NE(info.out.find("NOT scannable"), std::string::npos) << info.out;
    EXPECT_NE(info.err.find(expected), std::string::npos) << info.err;
    const auto scanned =
        scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
    EXPECT_EQ(scanned.exit_code, 1) << scanned.err;
    EXPECT_NE(scanned.err.find(expected), std::string::npos) << scanned.err;
  }
}

TEST_F(ScanHostileInput, AnImuTxtOverItsSizeLimitIsRefusedUnread) {
  const fs::path seq = synthesize(scratch_.path(), "room", 4, 57);
  // Sparse: 513 MiB of length, no data; the text limit is 512 MiB.
  fs::resize_file(seq / "imu.txt", std::uintmax_t{513} << 20);
  const auto info = tool("imufusion-info", seq.string());
  EXPECT_EQ(info.exit_code, 1) << info.err;
  EXPECT_NE(info.out.find("NOT scannable"), std::string::npos) << info.out;
  EXPECT_NE(info.err.find("imu.txt: larger than"), std::string::npos) << info.err;
  const auto scanned =
      scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
  EXPECT_EQ(scanned.exit_code, 1) << scanned.err;
  EXPECT_NE(scanned.err.find("imu.txt: larger than"), std::string::npos) << scanned.err;
}

TEST_F(ScanHostileInput, IntrinsicsNoCameraHasAreRefusedNamingTheValue) {
  const fs::path seq = synthesize(scratch_.path(), "room", 4, 53);
  for (const auto& [line, named] : {std::pair{"1e-06 100 79.5 59.5", "fx 1e-06"},
                                    std::pair{"100 100 1e+09 59.5", "cx 1e+09"}}) {
    std::ofstream(seq / "calibration.txt") << line << "\n";
    const auto scanned =
        scan_within_deadline(seq.string() + " --out " + path("out").string() + " --quiet");
    EXPECT_EQ(scanned.exit_code, 1) << scanned.err;
    EXPECT_NE(scanned.err.find(named), std::string::npos) << scanned.err;
    EXPECT_NE(scanned.err.find("calibration.txt"), std::string::npos) << scanned.err;
    const auto info = tool("imufusion-info", seq.string());
    EXPECT_EQ(info.exit_code, 1) << info.err;
    EXPECT_NE(info.out.find("NOT scannable"), std::string::npos) << info.out;
    EXPECT_NE(info.err.find(named), std::string::npos) << info.err;
  }
}

}  // namespace
}  // namespace imufusion
