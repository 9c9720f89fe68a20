// The generator's phone ToF model: noise that grows with depth and falls with reflectance, the
// 0.2-4 m range in millimetre steps, the weak-amplitude cut, and flying pixels at depth edges.

#include <gtest/gtest.h>

#include <cmath>

#include "imufusion/synth.hpp"

namespace imufusion::synth {
namespace {

Scene grey_plane_at(double z, float reflectance) {
  Scene scene;
  Material material;
  material.color = material.color2 = Eigen::Vector3f::Constant(reflectance);
  scene.planes.push_back(Plane{Eigen::Vector3d::UnitZ(), z, material});
  return scene;
}

// Errors of a head-on plane's pixels in units of each pixel's model sigma (its ray's incidence),
// the millimetre quantization added in quadrature: mean and standard deviation.
struct NormalizedErrors {
  double mean = 0, std = 0, metres_std = 0;
  int valid = 0;
};

NormalizedErrors plane_errors(double z, float reflectance) {
  const Intrinsics k = default_intrinsics(240, 180);
  const SensorModel model = sensor_model(SensorKind::kPhoneToF);
  const DepthImage raw =
      render_depth(grey_plane_at(z, reflectance), Eigen::Isometry3d::Identity(), k, model, 17);
  double sum = 0, sum2 = 0, metres2 = 0;
  NormalizedErrors e;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::uint16_t value = raw.data[static_cast<std::size_t>(v) * k.width + u];
      if (value == 0) continue;
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const double sigma =
          std::hypot(tof_noise_sigma(z, reflectance, 1.0 / ray.norm()), 0.001 / std::sqrt(12.0));
      const double error = value / model.depth_scale - z;
      sum += error / sigma;
      sum2 += (error / sigma) * (error / sigma);
      metres2 += error * error;
      ++e.valid;
    }
  }
  e.mean = sum / e.valid;
  e.std = std::sqrt(sum2 / e.valid - e.mean * e.mean);
  e.metres_std = std::sqrt(metres2 / e.valid);
  return e;
}

TEST(SynthPhoneToF, NamesAndFormat) {
  EXPECT_EQ(parse_sensor_kind(to_string(SensorKind::kPhoneToF)), SensorKind::kPhoneToF);
  EXPECT_EQ(parse_sensor_kind("kinect"), SensorKind::kKinect);
  EXPECT_FALSE(parse_sensor_kind("tof").has_value());
  const SensorFormat format = sensor_format(SensorKind::kPhoneToF);
  EXPECT_EQ(format.width, 240);
  EXPECT_EQ(format.height, 180);
  EXPECT_EQ(format.fps, 30.0);
  const SensorModel model = sensor_model(SensorKind::kPhoneToF);
  EXPECT_EQ(model.depth_scale, 1000.0);  // DEPTH16 millimetres
  // The Kinect model is SensorModel's defaults.
  const SensorModel kinect = sensor_model(SensorKind::kKinect);
  EXPECT_EQ(kinect.depth_scale, SensorModel{}.depth_scale);
  EXPECT_EQ(kinect.min_depth, SensorModel{}.min_depth);
  EXPECT_EQ(kinect.min_amplitude, 0.0);
}

// 43200 pixels per plane: the normalized std is within ~0.4 % of 1 (1 sd); allow 5 %.
TEST(SynthPhoneToF, NoiseIsAboutOnePercentOfDepthAndFollowsTheModel) {
  double previous = 0;
  for (const double z : {0.5, 1.0, 2.0, 3.5}) {
    const NormalizedErrors e = plane_errors(z, 0.5f);
    ASSERT_GT(e.valid, 40000) << "z " << z;
    EXPECT_NEAR(e.std, 1.0, 0.05) << "z " << z;
    EXPECT_NEAR(e.mean, 0.0, 0.05) << "z " << z;
    // Head-on at reflectance 0.5: 1 % of z at the centre, a little more toward the corners.
    EXPECT_GT(e.metres_std, 0.0095 * z) << "z " << z;
    EXPECT_LT(e.metres_std, 0.0125 * z) << "z " << z;
    EXPECT_GT(e.metres_std, previous);
    previous = e.metres_std;
  }
  EXPECT_NEAR(tof_noise_sigma(2.0, 0.5, 1.0), 0.02, 1e-12);
}

TEST(SynthPhoneToF, NoiseFallsWithReflectance) {
  const NormalizedErrors dark = plane_errors(2.0, 0.2f);
  const NormalizedErrors bright = plane_errors(2.0, 0.8f);
  EXPECT_NEAR(dark.std, 1.0, 0.05);
  EXPECT_NEAR(bright.std, 1.0, 0.05);
  // sigma ~ 1 / sqrt(reflectance): a quarter of the light, twice the noise.
  EXPECT_NEAR(dark.metres_std / bright.metres_std, 2.0, 0.1);
}

TEST(SynthPhoneToF, RangeIsPointTwoToFourMetresInMillimetres) {
  const Intrinsics k = default_intrinsics(40, 30);
  SensorModel model = sensor_model(SensorKind::kPhoneToF);
  model.depth_noise = false;
  auto valid_values = [&](double z) {
    const DepthImage raw =
        render_depth(grey_plane_at(z, 0.7f), Eigen::Isometry3d::Identity(), k, model, 1);
    int valid = 0;
    for (const std::uint16_t value : raw.data) {
      if (value == 0) continue;
      ++valid;
      EXPECT_NEAR(value, z * 1000.0, 0.5);  // the centre's depth, whole millimetres
    }
    return valid;
  };
  const int all = k.width * k.height;
  EXPECT_EQ(valid_values(0.15), 0);
  EXPECT_EQ(valid_values(0.25), all);
  EXPECT_EQ(valid_values(3.9), all);
  EXPECT_EQ(valid_values(4.1), 0);
}

TEST(SynthPhoneToF, WeakReturnsHaveNoDepth) {
  const Intrinsics k = default_intrinsics(40, 30);
  SensorModel model = sensor_model(SensorKind::kPhoneToF);
  model.depth_noise = false;
  // 0.05 / 2.5^2 = 0.008 < min_amplitude 0.02: a dark wall at 2.5 m gives nothing.
  const DepthImage dark =
      render_depth(grey_plane_at(2.5, 0.05f), Eigen::Isometry3d::Identity(), k, model, 1);
  for (const std::uint16_t value : dark.data) EXPECT_EQ(value, 0);
  const DepthImage near =
      render_depth(grey_plane_at(1.0, 0.05f), Eigen::Isometry3d::Identity(), k, model, 1);
  for (const std::uint16_t value : near.data) EXPECT_NE(value, 0);
}

// A box 1.5 m away in front of a wall at 3 m: Kinect leaves no depth between the two surfaces;
// the ToF model gives about half of the edge pixels depths between them, and drops the rest.
TEST(SynthPhoneToF, DepthEdgesHaveFlyingPixels) {
  Scene scene = grey_plane_at(3.0, 0.7f);
  Box box;
  box.center = Eigen::Vector3d(0.0, 0.0, 1.8);
  box.half_extents = Eigen::Vector3d(0.4, 0.3, 0.3);
  scene.boxes.push_back(box);
  const Intrinsics k = default_intrinsics(240, 180);
  auto between = [&](SensorKind kind) {
    SensorModel model = sensor_model(kind);
    model.depth_noise = false;
    const DepthImage raw = render_depth(scene, Eigen::Isometry3d::Identity(), k, model, 3);
    int count = 0, missing = 0;
    for (const std::uint16_t value : raw.data) {
      const double z = value / model.depth_scale;
      if (value == 0) ++missing;
      if (z > 1.52 && z < 2.98) ++count;
    }
    return std::pair{count, missing};
  };
  const auto [kinect_between, kinect_missing] = between(SensorKind::kKinect);
  const auto [tof_between, tof_missing] = between(SensorKind::kPhoneToF);
  EXPECT_EQ(kinect_between, 0);
  // The box's outline (104 x 60 px) has about 650 edge pixels on its two sides, half of them
  // flying.
  EXPECT_GT(tof_between, 200);
  EXPECT_LT(tof_between, 450);
  EXPECT_GT(tof_missing, 50);
  EXPECT_LT(tof_missing, kinect_missing);
}

}  // namespace
}  // namespace imufusion::synth
