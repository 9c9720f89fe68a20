// The tools' pictures of the model (tools/overview_image.hpp, overview_pose.hpp,
// model_outputs.hpp's path_of): colour over shading, 2x downsampling, the drawn camera path and
// the overview camera's framing.

#include <gtest/gtest.h>

#include <random>

#include "../../tools/model_outputs.hpp"

namespace imufusion::tools {
namespace {

ColorImage filled(int w, int h, Rgb c) {
  ColorImage img;
  img.width = w;
  img.height = h;
  for (int i = 0; i < w * h; ++i) img.data.insert(img.data.end(), c.begin(), c.end());
  return img;
}

Rgb pixel(const ColorImage& img, int u, int v) {
  const std::size_t i = (static_cast<std::size_t>(v) * img.width + u) * 3;
  return {img.data[i], img.data[i + 1], img.data[i + 2]};
}

TEST(ModelPicture, ColourWhereFusedShadingElsewhere) {
  RaycastImages r;
  r.shaded = filled(2, 1, {200, 200, 200});
  r.color = filled(2, 1, {0, 0, 0});
  r.color.data[3] = 100;  // the second pixel: fused colour (100, 0, 0)
  r.vertices.width = 2;
  r.vertices.height = 1;
  r.vertices.data.assign(2, Eigen::Vector4f(0, 0, 1, 1));  // both rays hit
  const ColorImage out = model_picture(r);
  EXPECT_EQ(pixel(out, 0, 0), (Rgb{210, 210, 210}));  // 48 + 200 * 207 / 255
  const Rgb coloured = pixel(out, 1, 0);
  EXPECT_NEAR(coloured[0], 100 * (0.35 + 0.75 * 200 / 255.0), 1.0);
  EXPECT_EQ(coloured[1], 0);
  EXPECT_EQ(coloured[2], 0);
  // Darker shading darkens the colour: shape shows through it.
  r.shaded.data[3] = r.shaded.data[4] = r.shaded.data[5] = 50;
  EXPECT_LT(pixel(model_picture(r), 1, 0)[0], coloured[0]);
  // Seen from behind (no light): still visible; no hit: black.
  r.shaded.data[0] = r.shaded.data[1] = r.shaded.data[2] = 0;
  EXPECT_EQ(pixel(model_picture(r), 0, 0), (Rgb{48, 48, 48}));
  r.vertices.data[0].w() = 0;
  EXPECT_EQ(pixel(model_picture(r), 0, 0), (Rgb{0, 0, 0}));
}

TEST(Downsample2x, AveragesEachBlockAndDropsOddEdges) {
  ColorImage img = filled(5, 3, {0, 0, 0});
  for (int v = 0; v < 2; ++v)
    for (int u = 0; u < 2; ++u)
      img.data[(v * 5 + u) * 3] = static_cast<std::uint8_t>(40 * (u + 2 * v));
  const ColorImage out = downsample_2x(img);
  ASSERT_EQ(out.width, 2);
  ASSERT_EQ(out.height, 1);
  EXPECT_EQ(pixel(out, 0, 0)[0], (0 + 40 + 80 + 120) / 4);
  EXPECT_EQ(pixel(out, 1, 0)[0], 0);
}

TEST(DrawPath, TrackedAndLostStretchesInTheirColours) {
  Intrinsics k;
  k.fx = k.fy = 100;
  k.cx = 50;
  k.cy = 40;
  k.width = 101;
  k.height = 81;
  ColorImage img = filled(k.width, k.height, {0, 0, 0});
  // At depth 1 m, x = 0.3 m is 30 pixels right of the centre.
  const std::vector<PathPoint> path = {
      {{-0.3, 0, 1}, true}, {{0, 0, 1}, true}, {{0.3, 0, 1}, false}};
  draw_path(img, k, Eigen::Isometry3d::Identity(), path, 3.0);
  EXPECT_EQ(pixel(img, 35, 40), kTrackedPathColor);
  EXPECT_EQ(pixel(img, 65, 40), kLostPathColor);
  EXPECT_EQ(pixel(img, 50, 20), (Rgb{0, 0, 0}));  // off the line
  EXPECT_EQ(pixel(img, 10, 40), (Rgb{0, 0, 0}));  // beyond its ends
  EXPECT_EQ(pixel(img, 90, 40), (Rgb{0, 0, 0}));
  // A segment with an end behind the camera is left out.
  ColorImage behind = filled(k.width, k.height, {0, 0, 0});
  draw_path(behind, k, Eigen::Isometry3d::Identity(), {{{0, 0, 1}, true}, {{0, 0, -1}, true}});
  EXPECT_EQ(std::count(behind.data.begin(), behind.data.end(), 0u), behind.data.size());
}

TEST(OverviewPose, EveryPointInsideAndTheModelFillsTheImage) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-2.0, 3.0), y(-1.0, 1.5), z(0.5, 6.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 500; ++i) points.emplace_back(x(rng), y(rng), z(rng));
  Eigen::Isometry3d first = Eigen::Isometry3d::Identity();
  first.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Intrinsics k = overview_intrinsics(320, 240);
  const Eigen::Isometry3d T = overview_pose(points, first, k);
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d c = T.inverse() * p;
    ASSERT_GT(c.z(), 0);
    const Eigen::Vector2d px(k.fx * c.x() / c.z() + k.cx, k.fy * c.y() / c.z() + k.cy);
    lo = lo.cwiseMin(px);
    hi = hi.cwiseMax(px);
  }
  EXPECT_GE(lo.minCoeff(), 0.0);
  EXPECT_LE(hi.x(), k.width);
  EXPECT_LE(hi.y(), k.height);
  // Tight: the points span at least 85% of the image in one direction.
  EXPECT_GT(std::max((hi.x() - lo.x()) / k.width, (hi.y() - lo.y()) / k.height), 0.85);
  // Looking down (camera y has a component along the first pose's down axis).
  EXPECT_GT(T.linear().col(2).dot(first.linear().col(1)), 0.3);
}

TEST(PathOf, MarksThePosesListedAsLost) {
  Trajectory t(4);
  for (int i = 0; i < 4; ++i) {
    t[i].timestamp = 0.1 * i;
    t[i].T_world_camera.translation() = Eigen::Vector3d(i, 0, 0);
  }
  const auto path = path_of(t, {0.1, 0.3});
  ASSERT_EQ(path.size(), 4u);
  EXPECT_TRUE(path[0].tracked);
  EXPECT_FALSE(path[1].tracked);
  EXPECT_TRUE(path[2].tracked);
  EXPECT_FALSE(path[3].tracked);
  EXPECT_EQ(path[3].position.x(), 3.0);
  for (const PathPoint& p : path_of(t)) EXPECT_TRUE(p.tracked);
}

}  // namespace
}  // namespace imufusion::tools
