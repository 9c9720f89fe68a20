// Every .glb that write_glb() produces must pass the Khronos glTF Validator with no errors.
// The validator is a Node.js package that .ci/install-deps puts in .ci/node_modules; without
// Node or the package the test is skipped, except under CI (the CI variable set), where it fails.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "../unit/mesh_test_fixtures.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/synth.hpp"
#include "reference/volume_reference.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

const fs::path kScript = fs::path(IMUFUSION_SOURCE_DIR) / ".ci" / "gltf-validate";
const fs::path kModule = fs::path(IMUFUSION_SOURCE_DIR) / ".ci" / "node_modules" / "gltf-validator";

bool in_ci() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && *ci != '\0' && std::string(ci) != "0" && std::string(ci) != "false";
}

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_all(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

class GltfValidator : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string missing;
    if (shell("node --version >/dev/null 2>&1") != 0) {
      missing = "node is not on PATH";
    } else if (!fs::exists(kModule / "package.json")) {
      missing = "the gltf-validator package is not in " + kModule.parent_path().string() +
                " (run .ci/install-deps)";
    }
    if (!missing.empty()) {
      if (in_ci()) FAIL() << "CI is set but " << missing;
      GTEST_SKIP() << missing;
    }
    dir_ = fs::temp_directory_path() /
           ("imufusion_gltf_validator_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }

  // Runs the validator; returns its exit status, the parsed report in `report`.
  int validate(const fs::path& glb, nlohmann::json& report) const {
    const fs::path out = dir_ / "report.json";
    const int rc = shell("node '" + kScript.string() + "' '" + glb.string() + "' >'" +
                         out.string() + "' 2>'" + (dir_ / "stderr.txt").string() + "'");
    report = nlohmann::json::parse(read_all(out), nullptr, false);
    return rc;
  }

  fs::path dir_;
};

Mesh sphere_mesh(bool colors) {
  auto color = [](const Eigen::Vector3d& p) {
    return std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(128 + std::lround(p.x() * 500)),
                                       static_cast<std::uint8_t>(128 + std::lround(p.y() * 500)),
                                       90};
  };
  const HostVolume volume = test::make_sdf_volume(
      test::sphere_sdf(Eigen::Vector3d(0.004, 0.011, -0.007), 0.15), Eigen::Vector3i::Constant(-3),
      Eigen::Vector3i::Constant(3), 0.01f, 4.0f, color);
  MeshOptions options;
  options.colors = colors;
  return extract_mesh(volume, options).value();
}

TEST_F(GltfValidator, MarchingCubesSphereWithAndWithoutColoursHasNoErrors) {
  for (bool colors : {true, false}) {
    const Mesh mesh = sphere_mesh(colors);
    ASSERT_GT(mesh.triangles.size(), 100u);
    const fs::path glb = dir_ / (colors ? "colored.glb" : "plain.glb");
    const Status written = write_glb(glb, mesh);
    ASSERT_TRUE(written.ok()) << written.error().describe();
    nlohmann::json report;
    const int rc = validate(glb, report);
    ASSERT_FALSE(report.is_discarded()) << read_all(dir_ / "stderr.txt");
    EXPECT_EQ(rc, 0) << report.dump(2);
    EXPECT_EQ(report["issues"]["numErrors"], 0) << report.dump(2);
    EXPECT_EQ(report["info"]["generator"], "imufusion");
    EXPECT_EQ(report["info"]["totalVertexCount"], mesh.vertices.size());
    EXPECT_EQ(report["info"]["totalTriangleCount"], mesh.triangles.size());
  }
}

TEST_F(GltfValidator, FusedRoomMeshHasNoErrors) {
  // A mesh as a scan produces it: quantized TSDF (exact zeros give coincident vertices), open
  // borders, colours from the frames.
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 4);
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 4);
  const Intrinsics intrinsics = synth::default_intrinsics(160, 120);
  reference::CpuVolume volume(0.02, 0.08, 64);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Isometry3d pose = motion.pose_at(0.3 * i);
    const FloatImage depth = synth::raycast_depth(scene, pose, intrinsics);
    const ColorImage color = synth::render_color(scene, pose, intrinsics);
    volume.fuse(depth, &color, intrinsics, pose);
  }
  const auto mesh = extract_mesh(volume.to_host_volume());
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  ASSERT_GT(mesh->triangles.size(), 1000u);
  const fs::path glb = dir_ / "room.glb";
  ASSERT_TRUE(write_glb(glb, *mesh).ok());
  nlohmann::json report;
  const int rc = validate(glb, report);
  ASSERT_FALSE(report.is_discarded()) << read_all(dir_ / "stderr.txt");
  EXPECT_EQ(rc, 0);
  EXPECT_EQ(report["issues"]["numErrors"], 0) << report["issues"].dump(2);
}

TEST_F(GltfValidator, ReportsErrorsInABrokenFile) {
  // The same file with the POSITION bounds corrupted: the validator must notice, which shows
  // that a passing result above means something.
  const fs::path glb = dir_ / "broken.glb";
  ASSERT_TRUE(write_glb(glb, sphere_mesh(true)).ok());
  std::string bytes;
  {
    std::ifstream in(glb, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const auto at = bytes.find("\"max\":[");
  ASSERT_NE(at, std::string::npos);
  bytes[at + 7] = bytes[at + 7] == '9' ? '8' : '9';  // a different leading digit
  std::ofstream(glb, std::ios::binary | std::ios::trunc) << bytes;
  nlohmann::json report;
  EXPECT_EQ(validate(glb, report), 1) << report.dump(2);
  ASSERT_FALSE(report.is_discarded());
  EXPECT_GT(report["issues"]["numErrors"], 0);
}

}  // namespace
}  // namespace imufusion
