// The synthetic depth renderer: exact ray casts of known primitives, the Kinect-like noise and
// range model, dropouts, determinism.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "imufusion/synth.hpp"

namespace imufusion::synth {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Scene plane_scene(const Eigen::Vector3d& normal, double offset) {
  Scene scene;
  scene.planes.push_back(Plane{normal.normalized(), offset, Material{}});
  return scene;
}

Eigen::Vector3d pixel_ray(const Intrinsics& k, int u, int v) {
  return Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
}

TEST(SynthRender, DefaultIntrinsicsScaleWithSize) {
  const Intrinsics full = default_intrinsics();
  EXPECT_EQ(full.width, 640);
  EXPECT_DOUBLE_EQ(full.fx, 525.0);
  EXPECT_DOUBLE_EQ(full.cx, 319.5);
  EXPECT_DOUBLE_EQ(full.cy, 239.5);
  const Intrinsics small = default_intrinsics(160, 120);
  EXPECT_DOUBLE_EQ(small.fx, 131.25);
  EXPECT_DOUBLE_EQ(small.fy, 131.25);
  // Same convention as Intrinsics::at_level: a 4x downsample.
  const Intrinsics level2 = full.at_level(2);
  EXPECT_DOUBLE_EQ(small.cx, level2.cx);
  EXPECT_DOUBLE_EQ(small.cy, level2.cy);
}

TEST(SynthRender, TiltedPlaneRaycastIsAnalytic) {
  // Plane n . x = c in the camera frame of a camera at a non-trivial pose.
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  T_world_camera.linear() =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1.0, -0.2).normalized()).toRotationMatrix();
  T_world_camera.translation() = Eigen::Vector3d(0.5, -1.0, 2.0);
  const Eigen::Vector3d n_cam = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  const double c_cam = 2.2;
  // The same plane in world coordinates: n_w = R n_c, c_w = c_c + n_w . t.
  const Eigen::Vector3d n_world = T_world_camera.linear() * n_cam;
  const double c_world = c_cam + n_world.dot(T_world_camera.translation());
  const Scene scene = plane_scene(n_world, c_world);

  const Intrinsics k = default_intrinsics(97, 61);
  const FloatImage depth = raycast_depth(scene, T_world_camera, k);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const double expected = c_cam / n_cam.dot(pixel_ray(k, u, v));
      ASSERT_NEAR(depth.at(u, v), expected, 2e-6 * expected) << u << "," << v;
    }
  }

  // Through the sensor model without noise: exact quantization of the same depth.
  SensorModel model;
  model.depth_noise = false;
  const DepthImage raw = render_depth(scene, T_world_camera, k, model, 7);
  EXPECT_EQ(raw.depth_scale, 5000.0);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const double expected = c_cam / n_cam.dot(pixel_ray(k, u, v));
      ASSERT_EQ(raw.at(u, v), static_cast<std::uint16_t>(std::lround(expected * 5000.0)));
    }
  }
}

TEST(SynthRender, SphereAndBoxAtKnownPose) {
  // Camera at (1, 2, 1.5) looking along world +x (right = -y, down = -z).
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(0, -1, 0);
  R.col(1) = Eigen::Vector3d(0, 0, -1);
  R.col(2) = Eigen::Vector3d(1, 0, 0);
  T_world_camera.linear() = R;
  T_world_camera.translation() = Eigen::Vector3d(1.0, 2.0, 1.5);

  Scene scene;
  const Eigen::Vector3d sphere_center(3.0, 2.0, 1.5);  // 2 m ahead
  scene.spheres.push_back(Sphere{sphere_center, 0.4, Material{}});
  const Intrinsics k = default_intrinsics(64, 48);
  FloatImage depth = raycast_depth(scene, T_world_camera, k);
  int sphere_pixels = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      // Closed form: |t d - c|^2 = r^2 in the camera frame, nearest root.
      const Eigen::Vector3d d = pixel_ray(k, u, v);
      const Eigen::Vector3d c = T_world_camera.inverse() * sphere_center;
      const double a = d.squaredNorm(), b = -2.0 * d.dot(c), cc = c.squaredNorm() - 0.16;
      const double disc = b * b - 4 * a * cc;
      const double expected = disc < 0 ? 0.0 : (-b - std::sqrt(disc)) / (2 * a);
      ASSERT_NEAR(depth.at(u, v), expected, 1e-5) << u << "," << v;
      sphere_pixels += expected > 0 ? 1 : 0;
    }
  }
  EXPECT_GT(sphere_pixels, 50);
  EXPECT_NEAR(depth.at(32, 24), 1.6, 0.01);  // near the optical axis: 2 - r

  // A box rotated about z: its front face is seen at the analytic distance at the centre pixel.
  Scene box_scene;
  box_scene.boxes.push_back(
      Box{Eigen::Vector3d(4.0, 2.0, 1.5), Eigen::Vector3d(0.5, 0.7, 0.6), 0.0, Material{}});
  depth = raycast_depth(box_scene, T_world_camera, k);
  const Eigen::Vector3d centre_ray = pixel_ray(k, 32, 24);
  // Face x = 3.5 is 2.5 m ahead along the axis; the camera-frame ray's z is the depth.
  EXPECT_NEAR(depth.at(32, 24), 2.5, 1e-6);
  EXPECT_GT(centre_ray.z(), 0.0);
  const std::optional<RayHit> hit =
      intersect(box_scene, T_world_camera.translation(), R * pixel_ray(k, 25, 30));
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->point.x(), 3.5, 1e-9);
  EXPECT_NEAR(hit->normal.x(), -1.0, 1e-12);
}

TEST(SynthRender, CylinderSideAndCapAreExact) {
  Scene scene;
  scene.cylinders.push_back(Cylinder{Eigen::Vector2d(0.0, 0.0), 0.5, 0.0, 1.0, Material{}});
  // Horizontal ray at height 0.5 toward the axis hits the side at x = -0.5.
  std::optional<RayHit> hit =
      intersect(scene, Eigen::Vector3d(-3.0, 0.0, 0.5), Eigen::Vector3d(2.0, 0.0, 0.0));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 1.25, 1e-12);  // direction has length 2
  EXPECT_NEAR(hit->normal.x(), -1.0, 1e-12);
  // From above, the top cap at z = 1.
  hit = intersect(scene, Eigen::Vector3d(0.1, 0.2, 3.0), Eigen::Vector3d(0.0, 0.0, -1.0));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->point.z(), 1.0, 1e-12);
  EXPECT_NEAR(hit->normal.z(), 1.0, 1e-12);
  // Passing above the cap misses.
  EXPECT_FALSE(intersect(scene, Eigen::Vector3d(-3.0, 0.0, 1.2), Eigen::Vector3d(1.0, 0.0, 0.0)));
}

TEST(SynthRender, NoiseStdFollowsKinectModel) {
  const Intrinsics k = default_intrinsics(160, 120);
  SensorModel model;  // noise on
  for (const double z : {1.0, 2.0, 3.5}) {
    const Scene scene = plane_scene(Eigen::Vector3d::UnitZ(), z);
    const DepthImage raw = render_depth(scene, Eigen::Isometry3d::Identity(), k, model, 11);
    double sum = 0, sum2 = 0;
    int n = 0;
    for (const std::uint16_t value : raw.data) {
      ASSERT_NE(value, 0);
      const double e = value / 5000.0 - z;
      sum += e;
      sum2 += e * e;
      ++n;
    }
    const double mean = sum / n;
    const double std = std::sqrt(sum2 / n - mean * mean);
    const double sigma = depth_noise_sigma(z);
    // 19200 samples: the sample std is within ~0.5% of sigma (1 sd), the mean within sigma/139.
    // Quantization (0.2 mm steps) adds 0.06 mm in quadrature. Allow 5% and 5 standard errors.
    EXPECT_NEAR(std, std::hypot(sigma, 0.0002 / std::sqrt(12.0)), 0.05 * sigma) << "z " << z;
    EXPECT_NEAR(mean, 0.0, 5.0 * sigma / std::sqrt(n)) << "z " << z;
  }
  EXPECT_NEAR(depth_noise_sigma(0.4), 0.0012, 1e-12);
  EXPECT_NEAR(depth_noise_sigma(2.4), 0.0012 + 0.0019 * 4.0, 1e-12);
}

TEST(SynthRender, KinectDepthLiesOnDisparitySteps) {
  const Intrinsics k = default_intrinsics(160, 120);
  const SensorModel model;
  const DepthImage raw = render_depth(plane_scene(Eigen::Vector3d::UnitZ(), 2.0),
                                      Eigen::Isometry3d::Identity(), k, model, 5);
  EXPECT_NEAR(disparity_depth_step(2.0, model), 4.0 * 0.125 / 43.5, 1e-12);
  int distinct_steps = 0;
  double previous = 0.0;
  for (const std::uint16_t value : raw.data) {
    ASSERT_NE(value, 0);
    const double z = value / 5000.0;
    const double steps = std::round(model.baseline_focal / z / model.disparity_step);
    const double z_step = model.baseline_focal / (steps * model.disparity_step);
    // Written in 1/5000 m: within half of that of a disparity step's depth.
    ASSERT_LE(std::abs(z - z_step), 0.5 / 5000.0 + 1e-9) << value;
    if (steps != previous) ++distinct_steps, previous = steps;
  }
  EXPECT_GT(distinct_steps, 10);  // the noise moves pixels across steps
}

/// Correlation of horizontal neighbours' depth errors and the share of pixel triples along rows
/// with a zero second difference, over a fronto-parallel plane at z.
std::pair<double, double> neighbour_structure(const DepthImage& raw, double z) {
  double sxy = 0, sxx = 0, mean = 0;
  int n = 0, flat = 0, triples = 0;
  for (const std::uint16_t value : raw.data) mean += value / 5000.0 - z;
  mean /= static_cast<double>(raw.data.size());
  for (int v = 0; v < raw.height; ++v) {
    for (int u = 0; u + 1 < raw.width; ++u) {
      const double a = raw.at(u, v) / 5000.0 - z - mean, b = raw.at(u + 1, v) / 5000.0 - z - mean;
      sxy += a * b;
      sxx += a * a;
      ++n;
      if (u + 2 < raw.width) {
        flat += raw.at(u, v) - 2 * raw.at(u + 1, v) + raw.at(u + 2, v) == 0;
        ++triples;
      }
    }
  }
  return {sxy / sxx, static_cast<double>(flat) / triples};
}

TEST(SynthRender, KinectNoiseIsSharedOverTheWindow) {
  const Intrinsics k = default_intrinsics(640, 480);
  const Scene scene = plane_scene(Eigen::Vector3d::UnitZ(), 1.0);
  SensorModel model;
  const auto [correlation, flat] =
      neighbour_structure(render_depth(scene, Eigen::Isometry3d::Identity(), k, model, 3), 1.0);
  // A 9 px box shares 8/9 of neighbours' noise; the 2.9 mm steps at 1 m keep most of it.
  EXPECT_GT(correlation, 0.6);
  EXPECT_GT(flat, 0.3);
  const auto [white_correlation, white_flat] = neighbour_structure(
      render_depth(scene, Eigen::Isometry3d::Identity(), k, white_noise_model(model), 3), 1.0);
  EXPECT_LT(std::abs(white_correlation), 0.02);
  EXPECT_LT(white_flat, 0.1);
}

TEST(SynthRender, WhiteKinectNoiseFollowsTheModelPerPixel) {
  const Intrinsics k = default_intrinsics(160, 120);
  const SensorModel model = white_noise_model(SensorModel{});
  const DepthImage raw = render_depth(plane_scene(Eigen::Vector3d::UnitZ(), 2.0),
                                      Eigen::Isometry3d::Identity(), k, model, 11);
  double sum2 = 0;
  for (const std::uint16_t value : raw.data)
    sum2 += (value / 5000.0 - 2.0) * (value / 5000.0 - 2.0);
  const double sigma = depth_noise_sigma(2.0);
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(raw.data.size())), sigma, 0.03 * sigma);
}

TEST(SynthRender, RangeLimitsGiveZero) {
  const Intrinsics k = default_intrinsics(40, 30);
  SensorModel model;
  model.depth_noise = false;
  auto count_valid = [&](double z) {
    const DepthImage raw = render_depth(plane_scene(Eigen::Vector3d::UnitZ(), z),
                                        Eigen::Isometry3d::Identity(), k, model, 1);
    int valid = 0;
    for (const std::uint16_t value : raw.data) valid += value != 0 ? 1 : 0;
    return valid;
  };
  const int all = k.width * k.height;
  EXPECT_EQ(count_valid(0.35), 0);
  EXPECT_EQ(count_valid(0.45), all);
  EXPECT_EQ(count_valid(4.4), all);
  EXPECT_EQ(count_valid(4.6), 0);
}

TEST(SynthRender, GrazingAnglesAreDropped) {
  // A plane through (0, 0, 2) whose normal is 80 deg from the optical axis: the incidence
  // angle of the ray at image column u is 80 deg minus or plus the ray's horizontal angle.
  const Intrinsics k = default_intrinsics(160, 120);
  const Eigen::Vector3d n(std::sin(80 * kDeg), 0.0, std::cos(80 * kDeg));
  const Scene scene = plane_scene(n, n.z() * 2.0);
  SensorModel model;
  model.depth_noise = false;
  model.max_depth = 100.0;
  const DepthImage raw = render_depth(scene, Eigen::Isometry3d::Identity(), k, model, 1);
  const FloatImage exact = raycast_depth(scene, Eigen::Isometry3d::Identity(), k);
  int checked = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d = pixel_ray(k, u, v);
      if (exact.at(u, v) <= 0.0f) continue;
      const double incidence = std::acos(std::abs(n.dot(d)) / d.norm()) / kDeg;
      if (std::abs(incidence - 78.0) < 0.05 || exact.at(u, v) < 0.4) continue;
      EXPECT_EQ(raw.at(u, v) != 0, incidence < 78.0) << u << "," << v << " " << incidence;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(SynthRender, DepthEdgesAreDropped) {
  // A sphere 1.5 m ahead of a wall 3 m ahead: its silhouette pixels have no depth, its
  // interior and the open wall do.
  Scene scene = plane_scene(Eigen::Vector3d::UnitZ(), 3.0);
  scene.spheres.push_back(Sphere{Eigen::Vector3d(0, 0, 1.5), 0.3, Material{}});
  const Intrinsics k = default_intrinsics(160, 120);
  SensorModel model;
  model.depth_noise = false;
  const DepthImage raw = render_depth(scene, Eigen::Isometry3d::Identity(), k, model, 1);
  const FloatImage exact = raycast_depth(scene, Eigen::Isometry3d::Identity(), k);
  int edges = 0;
  for (int v = 1; v + 1 < k.height; ++v) {
    for (int u = 1; u + 1 < k.width; ++u) {
      const bool on_sphere = exact.at(u, v) < 2.0f;
      bool next_to_other = false;
      for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        next_to_other |= (exact.at(u + du, v + dv) < 2.0f) != on_sphere;
      }
      if (next_to_other) {
        EXPECT_EQ(raw.at(u, v), 0) << u << "," << v;
        ++edges;
      } else if (on_sphere) {
        // Interior of the sphere: valid unless seen at a grazing angle near the rim.
        const Eigen::Vector3d p = exact.at(u, v) * pixel_ray(k, u, v);
        const Eigen::Vector3d normal = (p - Eigen::Vector3d(0, 0, 1.5)).normalized();
        const double cos_inc = std::abs(normal.dot(p.normalized()));
        if (cos_inc > std::cos(77.0 * kDeg)) {
          EXPECT_NE(raw.at(u, v), 0) << u << "," << v;
        }
      } else {
        EXPECT_NE(raw.at(u, v), 0) << u << "," << v;
      }
    }
  }
  EXPECT_GT(edges, 40);
}

TEST(SynthRender, SameSeedSameImageOtherSeedDiffers) {
  const Scene scene = make_scene(SceneKind::kRoom, 3);
  const CameraMotion motion(SceneKind::kRoom, 3);
  const Intrinsics k = default_intrinsics(80, 60);
  const SensorModel model;
  const Eigen::Isometry3d pose = motion.pose_at(1.0);
  const RenderedFrame a = render_frame(scene, pose, k, model, 42, true);
  const RenderedFrame b = render_frame(scene, pose, k, model, 42, true);
  const RenderedFrame c = render_frame(scene, pose, k, model, 43, true);
  EXPECT_EQ(a.depth.data, b.depth.data);
  EXPECT_EQ(a.color.data, b.color.data);
  EXPECT_NE(a.depth.data, c.depth.data);
  // Colour does not depend on the noise seed, and render_color agrees with render_frame.
  EXPECT_EQ(a.color.data, c.color.data);
  EXPECT_EQ(render_color(scene, pose, k).data, a.color.data);
  EXPECT_EQ(render_depth(scene, pose, k, model, 42).data, a.depth.data);
  // Other scene seeds change the colours (not the geometry).
  const Scene other = make_scene(SceneKind::kRoom, 4);
  EXPECT_NE(render_color(other, pose, k).data, a.color.data);
  EXPECT_EQ(raycast_depth(other, pose, k).data, raycast_depth(scene, pose, k).data);
}

TEST(SynthRender, ColourHasFloorCheckerAndShading) {
  // Looking straight down at the room floor: the 0.5 m checker gives two clearly different
  // colours in one image.
  const Scene scene = make_scene(SceneKind::kRoom, 1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(1, 0, 0);
  R.col(1) = Eigen::Vector3d(0, -1, 0);
  R.col(2) = Eigen::Vector3d(0, 0, -1);
  T.linear() = R;
  T.translation() = Eigen::Vector3d(1.6, 1.4, 1.5);  // above bare floor
  const ColorImage color = render_color(scene, T, default_intrinsics(80, 60));
  int dark = 0, light = 0;
  for (std::size_t i = 0; i < color.data.size(); i += 3) {
    const int sum = color.data[i] + color.data[i + 1] + color.data[i + 2];
    dark += sum < 250 ? 1 : 0;
    light += sum > 350 ? 1 : 0;
  }
  EXPECT_GT(dark, 500);
  EXPECT_GT(light, 500);
}

}  // namespace
}  // namespace imufusion::synth
