// Runs the built imufusion-fuse on a small synthetic room with ground-truth poses and checks its
// outputs: mesh files, previews, and the mesh's accuracy and completeness against the true
// surface as the tool reports them in summary.json. Also its failures on bad input.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>

#include "../../tools/overview_image.hpp"
#include "../support/picture_stats.hpp"
#include "../support/synth_config.hpp"
#include "imufusion/image_io.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

const fs::path kTool = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-fuse";

class FuseTool : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kTool)) << kTool << " was not built";
    std::random_device random;
    root_ = fs::temp_directory_path() / ("imufusion_fuse_" + std::to_string(random()));
    fs::create_directories(root_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }

  int run(const std::string& args, std::string* err = nullptr) {
    const fs::path err_file = root_ / "stderr.txt";
    const std::string command = kTool.string() + " " + args + " > " +
                                (root_ / "stdout.txt").string() + " 2> " + err_file.string();
    const int status = std::system(command.c_str());
    if (err != nullptr) {
      std::ifstream in(err_file);
      std::stringstream text;
      text << in.rdbuf();
      *err = text.str();
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  fs::path root_;
};

TEST_F(FuseTool, FusesASyntheticRoomIntoAnAccurateMesh) {
  const synth::SynthConfig config = test::small_synth_config(synth::SceneKind::kRoom, 21, 30);
  const fs::path sequence = root_ / "room";
  ASSERT_TRUE(synth::synthesize(config, sequence).ok());
  const fs::path out = root_ / "out";
  std::string err;
  ASSERT_EQ(run(sequence.string() + " --out " + out.string() + " --voxel-size 0.02 --quiet", &err),
            0)
      << err;
  for (const char* name : {"mesh.glb", "mesh.ply", "preview.png", "overview.png", "summary.json"})
    EXPECT_TRUE(fs::exists(out / name)) << name;
  auto mesh = read_mesh(out / "mesh.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  EXPECT_GT(mesh->triangles.size(), 1000u);
  EXPECT_EQ(mesh->colors.size(), mesh->vertices.size());
  auto preview = read_color_image(out / "preview.png");
  ASSERT_TRUE(preview.ok());
  EXPECT_EQ(preview->width, 160);
  EXPECT_GT(test::coloured_pixels(*preview), 160u * 120u / 4);  // the room's colours
  // The overview: the model fills it, the known poses' path is drawn in the tracked colour.
  auto overview = read_color_image(out / "overview.png");
  ASSERT_TRUE(overview.ok());
  EXPECT_GT(test::non_black_fraction(*overview), 0.15);  // ~0.2: a short scan sees part of the room
  EXPECT_GT(test::pixels_of(*overview, tools::kTrackedPathColor), 30u);
  EXPECT_EQ(test::pixels_of(*overview, tools::kLostPathColor), 0u);

  std::ifstream in(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["frames_fused"].get<int>(), 30);
  EXPECT_GT(summary["blocks_allocated"].get<int>(), 0);
  EXPECT_EQ(summary["pool_full_events"].get<int>(), 0);
  // 2 cm voxels, Kinect-like noise, 30 frames: accuracy well under a voxel, and nearly all of the
  // surface the camera saw is within 2 cm of the mesh.
  EXPECT_LT(summary["mesh_accuracy_mean"].get<double>(), 0.01);
  EXPECT_GT(summary["mesh_completeness"].get<double>(), 0.9);
}

TEST_F(FuseTool, MissingPosesOrSequenceIsAClearError) {
  synth::SynthConfig config;
  config.width = 64;
  config.height = 48;
  config.frames = 3;
  const fs::path sequence = root_ / "small";
  ASSERT_TRUE(synth::synthesize(config, sequence).ok());
  std::string err;
  EXPECT_EQ(run(sequence.string() + " --poses " + (root_ / "nope.txt").string(), &err), 1);
  EXPECT_NE(err.find("nope.txt"), std::string::npos) << err;
  EXPECT_EQ(run((root_ / "absent").string(), &err), 1);
  EXPECT_NE(err.find("absent"), std::string::npos) << err;
  EXPECT_EQ(run("", &err), 2);
  EXPECT_EQ(run(sequence.string() + " --voxel-size -1", &err), 2);
}

}  // namespace
}  // namespace imufusion
