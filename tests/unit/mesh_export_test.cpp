// PLY and glTF export: round trips, atomic replacement, empty and malformed meshes, bad files.

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <iterator>
#include <string>

#include "imufusion/mesh.hpp"
#include "mesh_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

class MeshExport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imufusion_mesh_export_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static Mesh sphere(bool colors) {
    auto color = [](const Eigen::Vector3d& p) {
      return std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(100 + std::lround(p.x() * 200)),
                                         17, 250};
    };
    const HostVolume volume = test::make_sdf_volume(
        test::sphere_sdf(Eigen::Vector3d(0.01, 0.02, 0.03), 0.12), Eigen::Vector3i::Constant(-3),
        Eigen::Vector3i::Constant(3), 0.01f, 4.0f, color);
    MeshOptions options;
    options.colors = colors;
    return extract_mesh(volume, options).value();
  }

  static std::string slurp(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

  int files_in_dir() const {
    return static_cast<int>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }

  fs::path dir_;
};

void expect_same_mesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_EQ(a.triangles, b.triangles);
}

TEST_F(MeshExport, PlyRoundTripWithAndWithoutColours) {
  for (bool colors : {true, false}) {
    const Mesh mesh = sphere(colors);
    ASSERT_GT(mesh.triangles.size(), 100u);
    const fs::path path = dir_ / "sphere.ply";
    ASSERT_TRUE(write_ply(path, mesh).ok());
    const std::string text = slurp(path);
    EXPECT_EQ(text.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
    EXPECT_EQ(text.find("property uchar red") != std::string::npos, colors);
    auto back = read_ply(path);
    ASSERT_TRUE(back.ok()) << back.error().describe();
    expect_same_mesh(*back, mesh);
    auto by_extension = read_mesh(path);
    ASSERT_TRUE(by_extension.ok());
    EXPECT_EQ(by_extension->triangles.size(), mesh.triangles.size());
  }
}

TEST_F(MeshExport, GlbRoundTripWithAndWithoutColours) {
  for (bool colors : {true, false}) {
    const Mesh mesh = sphere(colors);
    const fs::path path = dir_ / "sphere.glb";
    ASSERT_TRUE(write_glb(path, mesh).ok());
    const std::string bytes = slurp(path);
    ASSERT_GE(bytes.size(), 12u);
    EXPECT_EQ(bytes.substr(0, 4), "glTF");
    EXPECT_NE(bytes.find("\"generator\":\"imufusion\""), std::string::npos);
    EXPECT_EQ(bytes.find("COLOR_0") != std::string::npos, colors);
    auto back = read_gltf(path);
    ASSERT_TRUE(back.ok()) << back.error().describe();
    expect_same_mesh(*back, mesh);
    auto by_extension = read_mesh(dir_ / "sphere.GLB");
    EXPECT_FALSE(by_extension.ok());  // no such file (names are case-sensitive)
    EXPECT_TRUE(read_mesh(path).ok());
  }
}

TEST_F(MeshExport, EmptyMeshGivesAnEmptyPlyAndAGlbError) {
  const Mesh empty;
  ASSERT_TRUE(write_ply(dir_ / "empty.ply", empty).ok());
  auto back = read_ply(dir_ / "empty.ply");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_TRUE(back->vertices.empty());
  EXPECT_TRUE(back->triangles.empty());

  const Status glb = write_glb(dir_ / "empty.glb", empty);
  ASSERT_FALSE(glb.ok());
  EXPECT_EQ(glb.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(glb.error().message.find("no triangles"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "empty.glb"));
}

TEST_F(MeshExport, FailedWritesLeaveTheExistingFileAndNoTemporaries) {
  const Mesh first = sphere(true);
  for (const char* name : {"scan.ply", "scan.glb"}) {
    const fs::path path = dir_ / name;
    const bool ply = fs::path(name).extension() == ".ply";
    auto write = [&](const fs::path& p, const Mesh& m) {
      return ply ? write_ply(p, m) : write_glb(p, m);
    };
    ASSERT_TRUE(write(path, first).ok());
    const std::string before = slurp(path);

    Mesh broken = first;
    broken.triangles.back()[1] = static_cast<std::uint32_t>(broken.vertices.size());
    const Status bad = write(path, broken);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(bad.error().message.find(path.string()), std::string::npos);
    EXPECT_EQ(slurp(path), before);

    const Status missing = write(dir_ / "no_such_dir" / name, first);
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().code, ErrorCode::kIoError);

    // A successful rewrite replaces the whole file.
    Mesh smaller = first;
    smaller.triangles.resize(smaller.triangles.size() / 2);
    ASSERT_TRUE(write(path, smaller).ok());
    EXPECT_EQ(read_mesh(path)->triangles.size(), smaller.triangles.size());
  }
  EXPECT_EQ(files_in_dir(), 2);  // scan.ply and scan.glb, no leftover temporary files
}

TEST_F(MeshExport, RejectsMalformedMeshes) {
  Mesh mesh = sphere(true);
  Mesh fewer_normals = mesh;
  fewer_normals.normals.pop_back();
  EXPECT_FALSE(check_mesh(fewer_normals).ok());
  Mesh fewer_colors = mesh;
  fewer_colors.colors.pop_back();
  EXPECT_FALSE(write_ply(dir_ / "a.ply", fewer_colors).ok());
  Mesh nan = mesh;
  nan.vertices[3].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(write_glb(dir_ / "a.glb", nan).ok());
  EXPECT_TRUE(check_mesh(mesh).ok());
}

TEST_F(MeshExport, ReadErrorsNameTheFile) {
  auto missing = read_ply(dir_ / "missing.ply");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);

  const Mesh mesh = sphere(true);
  const fs::path path = dir_ / "cut.ply";
  ASSERT_TRUE(write_ply(path, mesh).ok());
  const std::string whole = slurp(path);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << whole.substr(0, whole.size() - 5);
  }
  auto truncated = read_ply(path);
  ASSERT_FALSE(truncated.ok());
  EXPECT_EQ(truncated.error().code, ErrorCode::kParseError);
  EXPECT_NE(truncated.error().message.find("cut.ply"), std::string::npos);
  EXPECT_NE(truncated.error().message.find("truncated"), std::string::npos);

  {
    // A count the file cannot hold is refused before anything is allocated for it.
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
           "property float x\nproperty float y\nproperty float z\nend_header\n";
  }
  auto huge = read_ply(path);
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.error().code, ErrorCode::kParseError);

  {
    std::ofstream out(path, std::ios::trunc);
    out << "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  }
  auto ascii = read_ply(path);
  ASSERT_FALSE(ascii.ok());
  EXPECT_EQ(ascii.error().code, ErrorCode::kUnsupported);

  {
    std::ofstream out(dir_ / "bad.glb", std::ios::binary);
    out << "glTF not really";
  }
  auto bad_glb = read_gltf(dir_ / "bad.glb");
  ASSERT_FALSE(bad_glb.ok());
  EXPECT_EQ(bad_glb.error().code, ErrorCode::kParseError);

  auto unknown = read_mesh(dir_ / "mesh.obj");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kUnsupported);
}

TEST_F(MeshExport, PlyWithoutNormalsGetsFaceNormals) {
  // A hand-written PLY: a unit square in z = 0 as one quad, double coordinates, no normals.
  const fs::path path = dir_ / "quad.ply";
  {
    std::ofstream out(path, std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\n"
           "property double y\nproperty double z\nelement face 1\n"
           "property list uchar int vertex_indices\nend_header\n";
    const double xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    out.write(reinterpret_cast<const char*>(xyz), sizeof(xyz));
    const unsigned char count = 4;
    const std::int32_t indices[4] = {0, 1, 2, 3};
    out.write(reinterpret_cast<const char*>(&count), 1);
    out.write(reinterpret_cast<const char*>(indices), sizeof(indices));
  }
  auto mesh = read_ply(path);
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  ASSERT_EQ(mesh->vertices.size(), 4u);
  ASSERT_EQ(mesh->triangles.size(), 2u);
  for (const auto& n : mesh->normals) EXPECT_TRUE(n.isApprox(Eigen::Vector3f::UnitZ()));
  EXPECT_TRUE(mesh->colors.empty());
}

}  // namespace
}  // namespace imufusion
