// Mesh files found by the fuzz harnesses of tests/fuzz (ply_fuzz, gltf_fuzz), and a glTF buffer
// that is a FIFO: each is refused with an error, or read into a mesh that check_mesh accepts;
// never read out of bounds, never waited on.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <future>
#include <limits>
#include <string>
#include <vector>

#include "imufusion/mesh.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

class MeshReadHostile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imufusion_mesh_read_hostile_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& bytes) const {
    std::ofstream(dir_ / name, std::ios::binary) << bytes;
    return dir_ / name;
  }

  fs::path dir_;
};

template <typename T>
std::string raw(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

std::string base64(const std::string& bytes) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t group = 0;
    for (std::size_t k = 0; k < n; ++k) {
      group |= std::uint32_t{static_cast<std::uint8_t>(bytes[i + k])} << (16 - 8 * k);
    }
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[(group >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

// One triangle as glTF JSON, its buffer a data URI: positions, then normals (9 floats each).
std::string triangle_gltf(const std::vector<float>& positions, const std::vector<float>& normals,
                          const std::string& buffer_uri = "") {
  const std::string buffer = raw(positions) + raw(normals);
  return R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":72,"uri":")" +
         (buffer_uri.empty() ? "data:application/octet-stream;base64," + base64(buffer)
                             : buffer_uri) +
         R"("}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},)"
         R"({"buffer":0,"byteOffset":36,"byteLength":36}],"accessors":[)"
         R"({"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},)"
         R"({"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"}],)"
         R"("meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"mode":4}]}]})";
}

TEST_F(MeshReadHostile, PlyWithASecondVertexElementIsRefused) {
  // ply_fuzz: a coloured vertex element, then one without colours, read the colours of the
  // second through column -1, past the end of the item's values.
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  const std::string body = raw(std::vector<float>{0, 0, 0}) + std::string("\x01\x02\x03", 3) +
                           raw(std::vector<float>{1, 0, 0, 0, 1, 0});
  auto mesh = read_ply(write("two.ply", header + body));
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().code, ErrorCode::kParseError);
  EXPECT_NE(mesh.error().message.find("vertex element"), std::string::npos) << mesh.error().message;
}

TEST_F(MeshReadHostile, PlyWithCoordinatesNearFloatsLimitGetsFiniteNormals) {
  // ply_fuzz: finite coordinates of 1e30 and more overflowed the cross product of the normals
  // computed for a file without them, which came out NaN.
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar uint vertex_indices\nend_header\n";
  const std::string body = raw(std::vector<float>{0, 0, 0, 1, 0, 2.5e30f, 3e32f, 1, 0}) +
                           std::string(1, '\x03') + raw(std::vector<std::uint32_t>{0, 1, 2});
  auto mesh = read_ply(write("far.ply", header + body));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  EXPECT_TRUE(check_mesh(*mesh).ok()) << check_mesh(*mesh).error().describe();
  for (const auto& n : mesh->normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
}

TEST_F(MeshReadHostile, PlyElementWithoutPropertiesIsSkippedWhateverItsCount) {
  // ply_fuzz: an element of no properties and a count of 4e8 in a 643-byte file took 16 s, as
  // the reader stepped through items that hold no bytes; with 1e18 it would never end.
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement nothing 1000000000000000000\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  const std::string body = raw(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}) +
                           std::string(1, '\x03') + raw(std::vector<std::uint32_t>{0, 1, 2});
  auto mesh = read_ply(write("empty_element.ply", header + body));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  EXPECT_EQ(mesh->vertices.size(), 3u);
  EXPECT_EQ(mesh->triangles.size(), 1u);
}

TEST_F(MeshReadHostile, PlyListCountBeyondTheFileIsRefused) {
  // ply_fuzz: a float list count of 4.5e30 was converted to an integer (undefined behaviour).
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list float uint vertex_indices\nend_header\n";
  const std::string body = raw(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 4.5e30f}) +
                           raw(std::vector<std::uint32_t>{0, 1, 2});
  auto mesh = read_ply(write("count.ply", header + body));
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().code, ErrorCode::kParseError);
  EXPECT_NE(mesh.error().message.find("face 0 has list count"), std::string::npos)
      << mesh.error().message;
}

TEST_F(MeshReadHostile, GltfWithANonFinitePositionIsRefused) {
  // gltf_fuzz: a NaN coordinate was read into a mesh that check_mesh (and write_ply) refuse.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> normals{0, 0, 1, 0, 0, 1, 0, 0, 1};
  auto mesh = read_gltf(write("nan.gltf", triangle_gltf({0, 0, 0, 1, nan, 0, 0, 1, 0}, normals)));
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().code, ErrorCode::kParseError);
  EXPECT_NE(mesh.error().message.find("nan.gltf"), std::string::npos) << mesh.error().message;
  EXPECT_NE(mesh.error().message.find("POSITION"), std::string::npos) << mesh.error().message;
}

TEST_F(MeshReadHostile, GltfNormalsBeyondReasonReadAsZero) {
  // As read_ply: a normal entry that is not finite (or beyond 1e6) reads as 0.
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> positions{0, 0, 0, 1, 0, 0, 0, 1, 0};
  auto mesh = read_gltf(write("inf.gltf", triangle_gltf(positions, {0, 0, 1, inf, 0, 1, 0, 0, 1})));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  EXPECT_TRUE(check_mesh(*mesh).ok()) << check_mesh(*mesh).error().describe();
  EXPECT_EQ(mesh->normals[1], Eigen::Vector3f(0, 0, 1));
}

TEST_F(MeshReadHostile, GltfBufferThatIsAFifoIsRefusedWithoutWaiting) {
  // tinygltf opened external buffers itself: a FIFO blocked the reader until a writer came.
  const fs::path fifo = dir_ / "buffer.bin";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::vector<float> triangle{0, 0, 0, 1, 0, 0, 0, 1, 0};
  const fs::path gltf = write("fifo.gltf", triangle_gltf(triangle, triangle, "buffer.bin"));
  auto read = std::async(std::launch::async, [&] { return read_gltf(gltf); });
  if (read.wait_for(std::chrono::seconds(20)) != std::future_status::ready) {
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // a writer that closes at once
    if (fd >= 0) ::close(fd);
    read.wait();
    FAIL() << "read_gltf blocked on " << fifo;
  }
  const auto mesh = read.get();
  ASSERT_FALSE(mesh.ok());
  EXPECT_NE(mesh.error().message.find("not a regular file"), std::string::npos)
      << mesh.error().message;

  fs::remove(fifo);  // the same buffer as a regular file is read
  write("buffer.bin", raw(triangle) + raw(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}));
  const auto regular = read_gltf(gltf);
  ASSERT_TRUE(regular.ok()) << regular.error().describe();
  EXPECT_EQ(regular->vertices.size(), 3u);
  EXPECT_EQ(regular->normals[2], Eigen::Vector3f(0, 0, 1));
}

}  // namespace
}  // namespace imufusion
