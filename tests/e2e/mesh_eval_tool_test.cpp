// imufusion-mesh-eval against the library: the room's shell as a mesh, seen along the synthetic
// camera path, must give the figures evaluate_mesh() gives, in text and JSON.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "../support/synth_config.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/mesh_eval.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

const fs::path kTool = fs::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-mesh-eval";

std::string read_all(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The boundary of the box [lo, hi] as 12 triangles (winding and normals do not matter here).
Mesh room_shell(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  Mesh mesh;
  for (int corner = 0; corner < 8; ++corner) {
    mesh.vertices.emplace_back((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                               (corner & 4) ? hi.z() : lo.z());
  }
  const std::array<std::array<std::uint32_t, 4>, 6> quads = {
      {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}}};
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  mesh.normals.assign(8, Eigen::Vector3f::UnitZ());
  return mesh;
}

class MeshEvalTool : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imufusion_mesh_eval_tool_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // 20 ground-truth poses, 0.5 s apart, of the room path.
    const synth::CameraMotion motion(synth::SceneKind::kRoom, 3);
    for (int i = 0; i < 20; ++i) poses_.push_back({0.5 * i, motion.pose_at(0.5 * i)});
    ASSERT_TRUE(write_trajectory(dir_ / "groundtruth.txt", poses_).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  int run(const std::string& arguments, std::string& out, std::string& err) const {
    const std::string command = "'" + kTool.string() + "' " + arguments + " >'" +
                                (dir_ / "out.txt").string() + "' 2>'" +
                                (dir_ / "err.txt").string() + "'";
    const int status = std::system(command.c_str());
    out = read_all(dir_ / "out.txt");
    err = read_all(dir_ / "err.txt");
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  fs::path dir_;
  Trajectory poses_;
};

TEST_F(MeshEvalTool, MatchesTheLibraryInTextAndJson) {
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 3);
  ASSERT_TRUE(scene.room.has_value());
  const Mesh shell = room_shell(scene.room->min.cast<float>(), scene.room->max.cast<float>());
  ASSERT_TRUE(write_ply(dir_ / "shell.ply", shell).ok());
  ASSERT_TRUE(write_glb(dir_ / "shell.glb", shell).ok());

  SurfaceSampleOptions samples;
  samples.pixel_step = 16;
  // The poses as the tool reads them (the file rounds them).
  const auto poses = read_trajectory(dir_ / "groundtruth.txt");
  ASSERT_TRUE(poses.ok());
  const auto reference =
      observed_surface_points(scene, *poses, synth::default_intrinsics(640, 480), samples);
  ASSERT_GT(reference.size(), 1000u);
  MeshEvalOptions eval;
  eval.sample_spacing = 0.05;
  const auto expected = evaluate_mesh(shell, scene, reference, eval);
  ASSERT_TRUE(expected.ok());
  // The shell is exact where it exists, and the furniture is missing from it.
  EXPECT_LT(expected->accuracy_p90, 1e-6);
  EXPECT_GT(expected->completeness, 0.2);
  EXPECT_LT(expected->completeness, 0.95);

  for (const char* name : {"shell.ply", "shell.glb"}) {
    std::string out, err;
    const std::string common = "'" + (dir_ / name).string() + "' --scene room --seed 3" +
                               " --groundtruth '" + (dir_ / "groundtruth.txt").string() +
                               "' --pixel-step 16 --spacing 0.05";
    ASSERT_EQ(run(common + " --json", out, err), 0) << err;
    const auto json = nlohmann::json::parse(out);
    EXPECT_EQ(json["reference_points"], reference.size());
    EXPECT_EQ(json["triangles"], 12);
    EXPECT_DOUBLE_EQ(json["completeness"].get<double>(), expected->completeness);
    EXPECT_NEAR(json["accuracy_mean_m"].get<double>(), expected->accuracy_mean, 1e-9);
    EXPECT_DOUBLE_EQ(json["completeness_threshold_m"].get<double>(), 0.02);

    ASSERT_EQ(run(common, out, err), 0) << err;
    EXPECT_NE(out.find("completeness"), std::string::npos) << out;
    EXPECT_NE(out.find("accuracy"), std::string::npos) << out;
  }

  // A looser threshold can only cover more.
  std::string out, err;
  ASSERT_EQ(run("'" + (dir_ / "shell.ply").string() + "' --scene room --seed 3 --groundtruth '" +
                    (dir_ / "groundtruth.txt").string() +
                    "' --pixel-step 16 --spacing 0.05 --threshold 0.5 --json",
                out, err),
            0)
      << err;
  EXPECT_GT(nlohmann::json::parse(out)["completeness"].get<double>(), expected->completeness);
}

TEST_F(MeshEvalTool, ReadsSceneSeedPosesAndCameraFromASequence) {
  synth::SynthConfig config = test::small_synth_config(synth::SceneKind::kWall, 5, 12);
  config.color = false;
  const fs::path sequence = dir_ / "sequence";
  ASSERT_TRUE(synth::synthesize(config, sequence).ok());
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kWall, 5);
  ASSERT_TRUE(write_ply(dir_ / "shell.ply",
                        room_shell(scene.room->min.cast<float>(), scene.room->max.cast<float>()))
                  .ok());

  std::string from_sequence, explicit_options, err;
  const std::string mesh = "'" + (dir_ / "shell.ply").string() + "' --spacing 0.05 --json";
  ASSERT_EQ(run(mesh + " --sequence '" + sequence.string() + "'", from_sequence, err), 0) << err;
  ASSERT_EQ(run(mesh + " --scene wall --seed 5 --size 160x120 --groundtruth '" +
                    (sequence / "groundtruth.txt").string() + "'",
                explicit_options, err),
            0)
      << err;
  const auto a = nlohmann::json::parse(from_sequence);
  const auto b = nlohmann::json::parse(explicit_options);
  EXPECT_EQ(a["scene"], "wall");
  EXPECT_EQ(a["poses"], 12);
  EXPECT_EQ(a["reference_points"], b["reference_points"]);
  EXPECT_EQ(a["completeness"], b["completeness"]);
  // A 640x480 camera sees more than the recorded 160x120 one at the same pixel step.
  ASSERT_EQ(
      run(mesh + " --sequence '" + sequence.string() + "' --size 640x480", explicit_options, err),
      0)
      << err;
  EXPECT_GT(nlohmann::json::parse(explicit_options)["reference_points"].get<int>(),
            a["reference_points"].get<int>());
}

TEST_F(MeshEvalTool, UsageAndInputErrors) {
  std::string out, err;
  EXPECT_EQ(run("--help", out, err), 0);
  EXPECT_NE(out.find("usage"), std::string::npos);
  EXPECT_EQ(run("mesh.ply --seed 1 --groundtruth gt.txt", out, err), 2);
  EXPECT_NE(err.find("--scene"), std::string::npos);
  EXPECT_EQ(run("mesh.ply --scene attic --seed 1 --groundtruth gt.txt", out, err), 2);
  EXPECT_EQ(run("mesh.ply --scene room --seed 1 --groundtruth gt.txt --size 640", out, err), 2);
  const std::string missing = "'" + (dir_ / "missing.ply").string() +
                              "' --scene room --seed 1 --groundtruth '" +
                              (dir_ / "groundtruth.txt").string() + "'";
  EXPECT_EQ(run(missing, out, err), 1);
  EXPECT_NE(err.find("missing.ply"), std::string::npos) << err;
}

}  // namespace
}  // namespace imufusion
