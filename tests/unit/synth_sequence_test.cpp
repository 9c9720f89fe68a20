// Whole synthetic sequences on disk: FORMAT.md layout, read back with the library's readers,
// byte-identical for one seed, and the imufusion-synth tool's command line.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "../support/synth_config.hpp"
#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"

namespace imufusion::synth {
namespace {

namespace fs = std::filesystem;

class SynthSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("imufusion_synth_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static SynthConfig small_config(SceneKind kind) {
    return test::small_synth_config(kind, 5, 12, 80, 60);
  }

  fs::path root_;
};

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Relative path -> content of every file under `dir`.
std::map<std::string, std::string> tree(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) {
      files[fs::relative(entry.path(), dir).string()] = slurp(entry.path());
    }
  }
  return files;
}

// Ground truth at every depth stamp, equal to the motion's pose.
void expect_ground_truth_follows(const fs::path& path, const SequenceInfo& info,
                                 const CameraMotion& motion) {
  const Result<Trajectory> gt = read_trajectory(path);
  ASSERT_TRUE(gt.ok()) << gt.error().describe();
  ASSERT_EQ(gt->size(), 12u);
  for (std::size_t i = 0; i < gt->size(); ++i) {
    EXPECT_NEAR((*gt)[i].timestamp, info.depth[i].timestamp, 1e-9);
    const Eigen::Isometry3d truth = motion.pose_at((*gt)[i].timestamp);
    EXPECT_LT(((*gt)[i].T_world_camera.translation() - truth.translation()).norm(), 1e-6);
    EXPECT_LT(
        Eigen::AngleAxisd(truth.linear().transpose() * (*gt)[i].T_world_camera.linear()).angle(),
        1e-6);
  }
}

TEST_F(SynthSequence, WritesFormatLayoutThatReadsBack) {
  const SynthConfig config = small_config(SceneKind::kRoom);
  const fs::path dir = root_ / "room";
  const Result<SynthSummary> summary = synthesize(config, dir);
  ASSERT_TRUE(summary.ok()) << summary.error().describe();
  EXPECT_EQ(summary->frames, 12);
  EXPECT_NEAR(summary->duration, 11.0 / 30.0, 1e-6);
  EXPECT_FALSE(fs::exists(root_ / "room.partial"));
  for (const char* name : {"depth.txt", "rgb.txt", "calibration.txt", "imu.txt",
                           "imu_to_camera.txt", "groundtruth.txt", "info.txt"}) {
    EXPECT_TRUE(fs::exists(dir / name)) << name;
  }

  const Result<SequenceReader> opened = SequenceReader::open(dir);
  ASSERT_TRUE(opened.ok()) << opened.error().describe();
  const SequenceReader& reader = opened.value();
  const SequenceInfo& info = reader.info();
  ASSERT_EQ(reader.frame_count(), 12u);
  EXPECT_EQ(info.width, 80);
  EXPECT_EQ(info.height, 60);
  EXPECT_EQ(info.depth_scale, 5000.0);
  EXPECT_EQ(info.color.size(), 12u);
  EXPECT_EQ(info.info.at("scene"), "room");
  EXPECT_EQ(info.info.at("seed"), "5");
  EXPECT_EQ(info.info.at("source"), "imufusion-synth");
  for (const char* key : {"imu_rate", "gyro_noise_density", "accel_noise_density"}) {
    EXPECT_TRUE(info.info.count(key)) << key;
  }

  // The true bias is in info.txt and is the mean gyro error.
  std::istringstream bias_text(info.info.at("gyro_bias"));
  Eigen::Vector3d bias;
  bias_text >> bias.x() >> bias.y() >> bias.z();
  EXPECT_LT((bias - summary->bias.gyro).cwiseAbs().maxCoeff(), 1e-9);  // 9 decimals
  const CameraMotion motion(config.scene, config.seed, config.start_time);
  ASSERT_TRUE(info.intrinsics.has_value());
  EXPECT_DOUBLE_EQ(info.intrinsics->fx, default_intrinsics(80, 60).fx);
  EXPECT_TRUE(info.T_camera_imu.isApprox(default_T_camera_imu(), 1e-8));
  const std::vector<ImuSample>& imu = reader.imu();
  ASSERT_FALSE(imu.empty());
  EXPECT_LT(imu.front().timestamp, info.depth.front().timestamp);
  EXPECT_GT(imu.back().timestamp, info.depth.back().timestamp);
  Eigen::Vector3d mean_error = Eigen::Vector3d::Zero();
  for (const ImuSample& s : imu) {
    mean_error += s.gyro - true_gyro(motion, info.T_camera_imu, s.timestamp);
  }
  mean_error /= static_cast<double>(imu.size());
  const double sigma = config.gyro_noise_density * std::sqrt(config.imu_rate);
  EXPECT_LT((mean_error - bias).cwiseAbs().maxCoeff(),
            5.0 * sigma / std::sqrt(static_cast<double>(imu.size())));

  expect_ground_truth_follows(dir / "groundtruth.txt", info, motion);

  // The images on disk are the in-memory renders at those poses.
  Result<Frame> frame = reader.frame(3);
  ASSERT_TRUE(frame.ok()) << frame.error().describe();
  SensorModel model;
  const RenderedFrame rendered =
      render_frame(make_scene(config.scene, config.seed), motion.pose_at(frame->timestamp),
                   default_intrinsics(80, 60), model, 0, true);
  ASSERT_TRUE(frame->color.has_value());
  EXPECT_EQ(frame->color->data, rendered.color.data);
  int valid = 0;
  for (std::size_t i = 0; i < rendered.depth.data.size(); ++i) {
    // Same sensor model, other noise seed: the same pixels are valid, depths agree to noise.
    EXPECT_EQ(frame->depth.data[i] != 0, rendered.depth.data[i] != 0);
    if (frame->depth.data[i] == 0 || rendered.depth.data[i] == 0) continue;
    ++valid;
    EXPECT_NEAR(frame->depth.data[i] / 5000.0, rendered.depth.data[i] / 5000.0, 0.1);
  }
  EXPECT_GT(valid, 80 * 60 / 2);
}

TEST_F(SynthSequence, SameSeedSameBytesOtherSeedDiffers) {
  SynthConfig config = small_config(SceneKind::kFast);
  config.frames = 4;
  ASSERT_TRUE(synthesize(config, root_ / "a").ok());
  ASSERT_TRUE(synthesize(config, root_ / "b").ok());
  config.seed = 6;
  ASSERT_TRUE(synthesize(config, root_ / "c").ok());
  const auto a = tree(root_ / "a");
  const auto b = tree(root_ / "b");
  const auto c = tree(root_ / "c");
  EXPECT_GE(a.size(), 4u * 2u + 7u);
  EXPECT_TRUE(a == b);
  EXPECT_NE(a.at("imu.txt"), c.at("imu.txt"));
  EXPECT_NE(a.at("groundtruth.txt"), c.at("groundtruth.txt"));
  // Same stamps (same fps and start), different images.
  ASSERT_EQ(a.count("depth.txt"), 1u);
  EXPECT_EQ(a.at("depth.txt"), c.at("depth.txt"));
  for (const auto& [name, content] : a) {
    if (name.rfind("depth/", 0) == 0) {
      EXPECT_NE(content, c.at(name)) << name;
    }
  }
}

TEST_F(SynthSequence, RefusesNonEmptyDirectoryAndBadConfig) {
  SynthConfig config = small_config(SceneKind::kRoom);
  config.frames = 2;
  const fs::path dir = root_ / "busy";
  fs::create_directories(dir);
  std::ofstream(dir / "keep.txt") << "mine\n";
  Result<SynthSummary> result = synthesize(config, dir);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(result.error().message.find("busy"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "keep.txt"));
  EXPECT_FALSE(fs::exists(root_ / "busy.partial"));

  config.overwrite = true;
  ASSERT_TRUE(synthesize(config, dir).ok());
  EXPECT_FALSE(fs::exists(dir / "keep.txt"));
  EXPECT_TRUE(fs::exists(dir / "depth.txt"));

  // A trailing slash names the same directory; the partial one is its sibling.
  config.overwrite = false;
  ASSERT_TRUE(synthesize(config, (root_ / "slash").string() + "/").ok());
  EXPECT_TRUE(fs::exists(root_ / "slash" / "depth.txt"));
  EXPECT_FALSE(fs::exists(root_ / "slash" / ".partial"));
  EXPECT_FALSE(synthesize(config, ".").ok());

  config.frames = 0;
  result = synthesize(config, root_ / "none");
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().code, ErrorCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(root_ / "none"));
  config.frames = 2;
  config.width = 0;
  EXPECT_FALSE(synthesize(config, root_ / "none").ok());
}

TEST_F(SynthSequence, WallSequenceRecordsItsStretch) {
  SynthConfig config = small_config(SceneKind::kWall);
  config.frames = 2;
  config.color = false;
  const Result<SynthSummary> summary = synthesize(config, root_ / "wall");
  ASSERT_TRUE(summary.ok()) << summary.error().describe();
  ASSERT_TRUE(summary->wall_stretch.has_value());
  const Result<SequenceReader> reader = SequenceReader::open(root_ / "wall");
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  std::istringstream text(reader->info().info.at("wall_stretch"));
  double begin = 0, end = 0;
  text >> begin >> end;
  EXPECT_NEAR(begin, summary->wall_stretch->begin, 1e-6);
  EXPECT_NEAR(end - begin, 2.0, 0.25);
  EXPECT_TRUE(reader->info().color.empty());
  EXPECT_FALSE(fs::exists(root_ / "wall" / "rgb.txt"));
}

int run_tool(const std::string& args, const fs::path& log) {
  const std::string command = std::string(IMUFUSION_TEST_BINARY_DIR) + "/tools/imufusion-synth " +
                              args + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST_F(SynthSequence, ToolWritesAndReportsUsageErrors) {
  const fs::path tool = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-synth";
  if (!fs::exists(tool)) GTEST_SKIP() << "tool not built: " << tool;
  const fs::path log = root_ / "log.txt";
  const fs::path out = root_ / "tool_out";
  ASSERT_EQ(run_tool("--scene wall --out " + out.string() +
                         " --frames 3 --size 64x48 --seed 2 --no-noise --no-color",
                     log),
            0)
      << slurp(log);
  const std::string printed = slurp(log);
  EXPECT_NE(printed.find("3 frames"), std::string::npos) << printed;
  EXPECT_NE(printed.find("64x48"), std::string::npos) << printed;
  const Result<SequenceReader> reader = SequenceReader::open(out);
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->frame_count(), 3u);
  EXPECT_EQ(reader->info().info.at("gyro_noise_density"), "0.000000000");

  EXPECT_EQ(run_tool("--out " + (root_ / "x").string(), log), 2);  // no scene
  EXPECT_NE(slurp(log).find("--scene is required"), std::string::npos);
  EXPECT_EQ(run_tool("--scene hall --out " + (root_ / "x").string(), log), 2);
  EXPECT_EQ(run_tool("--scene room --out " + (root_ / "x").string() + " --size 64by48", log), 2);
  EXPECT_EQ(run_tool("--scene room --out " + (root_ / "x").string() + " --frames", log), 2);
  EXPECT_EQ(run_tool("--scene room --out " + (root_ / "x").string() + " --bogus", log), 2);
  EXPECT_FALSE(fs::exists(root_ / "x"));
  // An existing sequence is not overwritten without --overwrite: a runtime error, exit 1.
  EXPECT_EQ(run_tool("--scene room --out " + out.string() + " --frames 2 --size 64x48", log), 1);
}

}  // namespace
}  // namespace imufusion::synth
