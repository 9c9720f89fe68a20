// Runs the built imufusion-info on small sequences written here: a good one, broken ones, and
// command-line misuse.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>

#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

const fs::path kTool = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-info";

struct ToolRun {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class InfoTool : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kTool)) << kTool << " was not built";
    std::random_device random;
    root_ = fs::temp_directory_path() /
            ("imufusion_info_tool_" + std::to_string(random()) + std::to_string(random()));
    fs::create_directories(root_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }

  // Writes a 6-frame 30 Hz sequence with colour, 200 Hz IMU, ground truth and calibration; with
  // `gap`, frame 4 comes 0.2 s late.
  fs::path write_sequence(const std::string& name, bool with_imu = true, bool gap = false) {
    const fs::path dir = root_ / name;
    auto writer = SequenceWriter::create(dir);
    EXPECT_TRUE(writer.ok());
    for (int i = 0; i < 6; ++i) {
      const double t = 50.0 + i / 30.0 + (gap && i >= 4 ? 0.2 : 0.0);
      DepthImage depth;
      depth.width = 16;
      depth.height = 12;
      depth.data.assign(16 * 12, static_cast<std::uint16_t>(5000 + i));
      EXPECT_TRUE(writer->add_depth(t, depth).ok());
      ColorImage color;
      color.width = 16;
      color.height = 12;
      color.data.assign(16 * 12 * 3, 128);
      EXPECT_TRUE(writer->add_color(t + 0.01, color).ok());
      EXPECT_TRUE(writer->add_ground_truth(StampedPose{t, Eigen::Isometry3d::Identity()}).ok());
    }
    for (int k = 0; with_imu && k < 100; ++k) {
      EXPECT_TRUE(writer
                      ->add_imu(ImuSample{49.99 + k * 0.005, Eigen::Vector3d::Zero(),
                                          Eigen::Vector3d(0, -9.81, 0)})
                      .ok());
    }
    EXPECT_TRUE(writer->set_intrinsics(Intrinsics{20, 20, 7.5, 5.5, 0, 0}).ok());
    EXPECT_TRUE(writer->finish().ok());
    return dir;
  }

  ToolRun run(const std::string& arguments) {
    const fs::path out = root_ / "stdout.txt", err = root_ / "stderr.txt";
    const std::string command = "\"" + kTool.string() + "\" " + arguments + " > \"" + out.string() +
                                "\" 2> \"" + err.string() + "\"";
    const int status = std::system(command.c_str());
    ToolRun result;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = slurp(out);
    result.err = slurp(err);
    return result;
  }

  static std::string quoted(const fs::path& path) { return "\"" + path.string() + "\""; }

  fs::path root_;
};

TEST_F(InfoTool, GoodSequenceIsScannable) {
  const fs::path dir = write_sequence("good");
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("depth: 6 frames"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("30.00 Hz"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("decoded: 6 of 6"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("fx 20 fy 20 cx 7.5 cy 5.5"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("colour: 6 frames (6 decoded), 6 of 6 depth frames matched"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("200.0 Hz"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("6 of 6 frames (100.0%)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("verdict: scannable"), std::string::npos) << result.out;
  EXPECT_TRUE(result.err.empty()) << result.err;  // no progress count: stderr is not a terminal
}

TEST_F(InfoTool, JsonSummary) {
  const fs::path dir = write_sequence("good");
  const ToolRun result = run(quoted(dir) + " --json");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto json = nlohmann::json::parse(result.out, nullptr, false);
  ASSERT_FALSE(json.is_discarded()) << result.out;
  EXPECT_EQ(json["depth"]["count"], 6);
  EXPECT_EQ(json["width"], 16);
  EXPECT_EQ(json["scannable"], true);
  EXPECT_EQ(json["intrinsics"]["fx"], 20.0);
  EXPECT_TRUE(json["problems"].empty());
}

TEST_F(InfoTool, TruncatedDepthImageIsNotScannable) {
  const fs::path dir = write_sequence("broken");
  const auto victim = dir / "depth" / "50.100000.png";
  ASSERT_TRUE(fs::exists(victim));
  fs::resize_file(victim, fs::file_size(victim) / 2);
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 1) << result.out << result.err;
  EXPECT_NE(result.err.find(victim.string()), std::string::npos) << result.err;
  EXPECT_NE(result.out.find("decoded: 5 of 6"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("NOT scannable"), std::string::npos) << result.out;
}

TEST_F(InfoTool, CorruptColourImageIsNotScannable) {
  const fs::path dir = write_sequence("bad_colour");
  const auto victim = dir / "rgb" / "50.043333.png";
  ASSERT_TRUE(fs::exists(victim));
  std::ofstream(victim, std::ios::trunc) << "garbage";
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find(victim.string()), std::string::npos) << result.err;
  EXPECT_NE(result.out.find("6 frames (5 decoded)"), std::string::npos) << result.out;
}

TEST_F(InfoTool, EveryMissingImageIsListed) {
  const fs::path dir = write_sequence("missing");
  fs::remove(dir / "depth" / "50.000000.png");
  fs::remove(dir / "depth" / "50.166667.png");
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find((dir / "depth.txt").string() + ":3:"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find((dir / "depth.txt").string() + ":8:"), std::string::npos) << result.err;
}

TEST_F(InfoTool, MissingIntrinsicsIsNotScannable) {
  const fs::path dir = write_sequence("uncalibrated");
  fs::remove(dir / "calibration.txt");
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.out.find("missing: pass intrinsics"), std::string::npos) << result.out;
  EXPECT_NE(result.err.find("calibration.txt"), std::string::npos) << result.err;
}

TEST_F(InfoTool, ImagesTooSmallForTheScansPyramidAreNotScannable) {
  // 6x4 decodes and has plausible intrinsics, but the scan's 3 pyramid levels need 8x8: the
  // scan fails ("cannot hold 3 pyramid levels"), so info must not call it scannable.
  const fs::path dir = root_ / "tiny";
  auto writer = SequenceWriter::create(dir);
  ASSERT_TRUE(writer.ok());
  for (int i = 0; i < 3; ++i) {
    DepthImage depth;
    depth.width = 6;
    depth.height = 4;
    depth.data.assign(6 * 4, static_cast<std::uint16_t>(5000));
    ASSERT_TRUE(writer->add_depth(10.0 + i / 30.0, depth).ok());
  }
  ASSERT_TRUE(writer->set_intrinsics(Intrinsics{5, 5, 3, 2, 0, 0}).ok());
  ASSERT_TRUE(writer->finish().ok());
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 1) << result.out;
  EXPECT_NE(result.out.find("NOT scannable"), std::string::npos) << result.out;
  EXPECT_NE(result.err.find("6x4 is too small to scan"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("8x8"), std::string::npos) << result.err;
}

TEST_F(InfoTool, NoImuAndGapsAreReportedButScannable) {
  const fs::path dir = write_sequence("no_imu", /*with_imu=*/false, /*gap=*/true);
  const ToolRun result = run(quoted(dir));
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("the scan will run without inertial aid"), std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("gaps: 1 depth intervals"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("after 50.100000"), std::string::npos) << result.out;
}

TEST_F(InfoTool, MissingSequenceIsNotScannable) {
  const ToolRun result = run(quoted(root_ / "absent"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find((root_ / "absent").string()), std::string::npos) << result.err;
}

TEST_F(InfoTool, UsageErrors) {
  EXPECT_EQ(run("").exit_code, 2);
  EXPECT_EQ(run(quoted(root_) + " --frobnicate").exit_code, 2);
  EXPECT_EQ(run("a b").exit_code, 2);
  EXPECT_EQ(run("--help").exit_code, 0);
}

}  // namespace
}  // namespace imufusion
