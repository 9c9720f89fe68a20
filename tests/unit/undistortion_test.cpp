// The resampling of distorted frames to their pinhole (core/undistortion.hpp).
#include "core/undistortion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace imufusion {
namespace {

Intrinsics camera(std::array<double, 5> distortion) {
  return Intrinsics{150.0, 150.0, 79.5, 59.5, 160, 120, distortion};
}

TEST(Undistortion, APinholeNeedsNoResampling) {
  auto sources = undistortion_sources(camera({0, 0, 0, 0, 0}));
  ASSERT_TRUE(sources.ok());
  EXPECT_TRUE(sources->empty());
}

TEST(Undistortion, NonFiniteCoefficientsAreNamed) {
  auto sources =
      undistortion_sources(camera({0.1, std::numeric_limits<double>::quiet_NaN(), 0, 0, 0}));
  ASSERT_FALSE(sources.ok());
  EXPECT_NE(sources.error().message.find("k2"), std::string::npos) << sources.error().message;
}

// Barrel distortion (k1 < 0) pulls the frame's edges inwards: a pinhole pixel takes a pixel
// nearer the centre, the centre keeps its own, and every source lies in the frame. Pincushion
// (k1 > 0) pushes the corners' rays out of the frame.
TEST(Undistortion, SourcesFollowTheLens) {
  const Intrinsics barrel = camera({-0.2, 0, 0, 0, 0});
  auto sources = undistortion_sources(barrel);
  ASSERT_TRUE(sources.ok());
  ASSERT_EQ(sources->size(), 160u * 120u);
  const auto at = [&](int u, int v) { return (*sources)[static_cast<std::size_t>(v * 160 + u)]; };
  EXPECT_EQ(at(80, 60), 60 * 160 + 80);
  const std::int32_t corner = at(0, 0);
  ASSERT_GE(corner, 0);
  EXPECT_GT(corner % 160, 0);
  EXPECT_GT(corner / 160, 0);
  for (std::int32_t s : *sources) EXPECT_GE(s, 0);
  // Where the lens puts the corner's ray, in the model's own words.
  double xd = 0, yd = 0;
  distort_normalized(barrel, (0 - barrel.cx) / barrel.fx, (0 - barrel.cy) / barrel.fy, &xd, &yd);
  EXPECT_EQ(corner % 160, static_cast<int>(std::round(barrel.fx * xd + barrel.cx)));

  auto pincushion = undistortion_sources(camera({0.3, 0, 0, 0, 0}));
  ASSERT_TRUE(pincushion.ok());
  EXPECT_EQ((*pincushion)[0], -1);
  EXPECT_EQ((*pincushion)[60 * 160 + 80], 60 * 160 + 80);
}

// Tangential terms move the point off its radius: p1 moves it along y by p1 (r^2 + 2 y^2).
TEST(Undistortion, TangentialTermsFollowOpenCv) {
  const Intrinsics k = camera({0, 0, 0.01, -0.02, 0});
  double xd = 0, yd = 0;
  distort_normalized(k, 0.3, -0.2, &xd, &yd);
  const double r2 = 0.3 * 0.3 + 0.2 * 0.2;
  EXPECT_NEAR(xd, 0.3 + 2 * 0.01 * 0.3 * -0.2 + -0.02 * (r2 + 2 * 0.3 * 0.3), 1e-15);
  EXPECT_NEAR(yd, -0.2 + 0.01 * (r2 + 2 * 0.2 * 0.2) + 2 * -0.02 * 0.3 * -0.2, 1e-15);
}

}  // namespace
}  // namespace imufusion
