// Vertex/normal map pyramids (frame-to-model references) keep surfaces apart at depth jumps.

#include "reference/map_pyramid.hpp"

#include <gtest/gtest.h>

namespace imufusion {
namespace {

TEST(MapPyramid, AveragesBlocksWithoutCrossingDepthJumps) {
  Vec4Image v, n;
  v.width = n.width = 6;
  v.height = n.height = 4;
  v.data.assign(24, Eigen::Vector4f::Zero());
  n.data.assign(24, Eigen::Vector4f::Zero());
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) {
      const float z = x < 3 ? 1.0f : 3.0f;  // the jump lies inside the middle 2x2 blocks
      v.data[static_cast<std::size_t>(y * 6 + x)] =
          Eigen::Vector4f(0.01f * static_cast<float>(x), 0.01f * static_cast<float>(y), z, 1.0f);
      n.data[static_cast<std::size_t>(y * 6 + x)] = Eigen::Vector4f(0, 0, -1, 1);
    }
  }
  n.data[0].setZero();  // a pixel without a normal does not count
  const auto pyramid = build_map_pyramid(v, n, 2, 0.05f);
  ASSERT_EQ(pyramid.size(), 2u);
  const MapLevel& half = pyramid[1];
  ASSERT_EQ(half.vertices.width, 3);
  ASSERT_EQ(half.vertices.height, 2);
  EXPECT_FLOAT_EQ(half.vertices.data[0].z(), 1.0f);
  EXPECT_NEAR(half.vertices.data[0].x(), 0.01f * 2 / 3,
              1e-6);  // mean of x = 1, 0, 1 (pixel 0 left out)
  EXPECT_FLOAT_EQ(half.vertices.data[1].z(), 1.0f)
      << "the block across the jump keeps its near side";
  EXPECT_FLOAT_EQ(half.vertices.data[2].z(), 3.0f);
  EXPECT_FLOAT_EQ(half.normals.data[1].z(), -1.0f);
  EXPECT_EQ(half.normals.data[1].w(), 1.0f);
}

TEST(MapPyramid, EmptyBlocksStayInvalid) {
  Vec4Image v, n;
  v.width = n.width = 4;
  v.height = n.height = 4;
  v.data.assign(16, Eigen::Vector4f::Zero());
  n.data.assign(16, Eigen::Vector4f::Zero());
  const auto pyramid = build_map_pyramid(v, n, 3, 0.05f);
  ASSERT_EQ(pyramid.size(), 3u);
  EXPECT_EQ(pyramid[2].vertices.width, 1);
  for (const MapLevel& level : pyramid)
    for (const auto& p : level.vertices.data) EXPECT_EQ(p.w(), 0.0f);
}

}  // namespace
}  // namespace imufusion
