// The ground-truth camera paths: inside the room, smooth, looking at content; the wall scene's
// stretch sees only the wall; the fast scene reaches ~90 deg/s.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include "imufusion/synth.hpp"

namespace imufusion::synth {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

double rotation_angle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

struct ViewStats {
  std::set<int> near_objects;  // furniture ids seen between 1 and 3 m
  double valid_fraction = 0;   // pixels with a depth inside the sensor range
};

ViewStats view_stats(const Scene& scene, const Eigen::Isometry3d& T, const Intrinsics& k) {
  ViewStats stats;
  int valid = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      const std::optional<RayHit> hit = intersect(scene, T.translation(), T.linear() * d);
      if (!hit) continue;
      if (hit->t >= 0.4 && hit->t <= 4.5) ++valid;
      if (hit->primitive > 0 && hit->t >= 1.0 && hit->t <= 3.0) {
        stats.near_objects.insert(hit->primitive);
      }
    }
  }
  stats.valid_fraction = static_cast<double>(valid) / (k.width * k.height);
  return stats;
}

TEST(SynthMotion, PathsStayInsideTheRoomAndLookAtContent) {
  const Intrinsics k = default_intrinsics(64, 48);
  for (const SceneKind kind : {SceneKind::kRoom, SceneKind::kFast, SceneKind::kWall}) {
    for (const std::uint64_t seed : {1u, 2u, 3u}) {
      const Scene scene = make_scene(kind, seed);
      const CameraMotion motion(kind, seed, 100.0);
      const std::optional<TimeSpan> stretch = motion.wall_stretch();
      for (double tau = 0.0; tau <= 30.0; tau += 0.5) {
        const double t = 100.0 + tau;
        const Eigen::Isometry3d T = motion.pose_at(t);
        const Eigen::Vector3d p = T.translation();
        ASSERT_TRUE(p.x() > 0.5 && p.x() < 5.5 && p.y() > 0.5 && p.y() < 4.5) << p.transpose();
        ASSERT_TRUE(p.z() > 1.2 && p.z() < 1.7) << p.transpose();
        ASSERT_NEAR((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 0.0,
                    1e-12);
        ASSERT_NEAR(T.linear().determinant(), 1.0, 1e-12);
        if (stretch && t >= stretch->begin - 3.0 && t <= stretch->end + 3.0) continue;
        const ViewStats stats = view_stats(scene, T, k);
        EXPECT_GE(stats.near_objects.size(), 2u)
            << to_string(kind) << " seed " << seed << " t " << tau;
        EXPECT_GT(stats.valid_fraction, 0.6) << to_string(kind) << " seed " << seed << " t " << tau;
      }
    }
  }
}

TEST(SynthMotion, WalkingSpeedAndSmoothness) {
  for (const SceneKind kind : {SceneKind::kRoom, SceneKind::kWall, SceneKind::kFast}) {
    const CameraMotion motion(kind, 5);
    double path = 0, max_step = 0, max_turn = 0;
    const double dt = 0.001;
    Eigen::Isometry3d prev = motion.pose_at(0.0);
    for (double t = dt; t <= 20.0; t += dt) {
      const Eigen::Isometry3d T = motion.pose_at(t);
      const double step = (T.translation() - prev.translation()).norm();
      path += step;
      max_step = std::max(max_step, step);
      max_turn = std::max(max_turn, rotation_angle(prev.linear(), T.linear()));
      prev = T;
    }
    const double mean_speed = path / 20.0;
    if (kind == SceneKind::kFast) {
      EXPECT_GT(mean_speed, 0.45);
      EXPECT_LT(mean_speed, 1.0);
    } else {
      EXPECT_GT(mean_speed, 0.2) << to_string(kind);
      EXPECT_LT(mean_speed, 0.45) << to_string(kind);
    }
    // No jumps: below 1.5 m/s and 150 deg/s everywhere.
    EXPECT_LT(max_step / dt, 1.5) << to_string(kind);
    EXPECT_LT(max_turn / dt, 150.0 * kDeg) << to_string(kind);
  }
}

TEST(SynthMotion, DeterministicFromSeed) {
  const CameraMotion a(SceneKind::kRoom, 9), b(SceneKind::kRoom, 9), c(SceneKind::kRoom, 10);
  for (const double t : {0.0, 1.7, 12.3}) {
    EXPECT_TRUE(a.pose_at(t).matrix() == b.pose_at(t).matrix());
    EXPECT_FALSE(a.pose_at(t).isApprox(c.pose_at(t), 1e-3));
  }
  // start_time shifts the clock only.
  const CameraMotion shifted(SceneKind::kRoom, 9, 50.0);
  EXPECT_TRUE(shifted.pose_at(51.0).isApprox(a.pose_at(1.0), 1e-9));
}

TEST(SynthMotion, WallStretchSeesOnlyThePlaneWhileMoving) {
  const Intrinsics k = default_intrinsics(80, 60);
  for (const std::uint64_t seed : {1u, 2u, 7u}) {
    const Scene scene = make_scene(SceneKind::kWall, seed);
    const CameraMotion motion(SceneKind::kWall, seed, 10.0);
    const std::optional<TimeSpan> stretch = motion.wall_stretch();
    ASSERT_TRUE(stretch.has_value());
    EXPECT_NEAR(stretch->end - stretch->begin, 2.0, 0.25);
    SensorModel model;  // with noise: points still on the plane within 4 sigma
    Eigen::Isometry3d first = motion.pose_at(stretch->begin);
    double max_turn = 0;
    for (double t = stretch->begin; t <= stretch->end + 1e-9; t += 1.0 / 30.0) {
      const Eigen::Isometry3d T = motion.pose_at(t);
      EXPECT_NEAR(6.0 - T.translation().x(), 1.0, 0.1);
      max_turn = std::max(max_turn, rotation_angle(first.linear(), T.linear()));
      const DepthImage raw = render_depth(scene, T, k, model, 3);
      int valid = 0;
      for (int v = 0; v < k.height; ++v) {
        for (int u = 0; u < k.width; ++u) {
          const std::uint16_t value = raw.at(u, v);
          if (value == 0) continue;
          ++valid;
          const double z = value / raw.depth_scale;
          const Eigen::Vector3d p =
              T * Eigen::Vector3d(z * (u - k.cx) / k.fx, z * (v - k.cy) / k.fy, z);
          // x = 6 plane; along the ray the depth error moves x by at most the depth error.
          ASSERT_NEAR(p.x(), 6.0, 4.0 * depth_noise_sigma(z) + 0.001) << "t " << t;
          const std::optional<RayHit> hit =
              intersect(scene, T.translation(),
                        T.linear() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1));
          ASSERT_TRUE(hit && hit->primitive == 0 && std::abs(hit->normal.x() + 1.0) < 1e-12);
        }
      }
      EXPECT_EQ(valid, k.width * k.height) << "t " << t;
    }
    // Moving parallel to the wall, rotating a little.
    const Eigen::Vector3d moved = motion.pose_at(stretch->end).translation() - first.translation();
    EXPECT_GT(std::abs(moved.y()), 0.4);
    EXPECT_LT(std::abs(moved.x()), 0.1);
    EXPECT_GT(max_turn, 3.0 * kDeg);
    EXPECT_LT(max_turn, 20.0 * kDeg);
    // Before and after the episode the room's content is in view again.
    const ViewStats after = view_stats(scene, motion.pose_at(10.0 + motion.episode_end() + 0.5),
                                       default_intrinsics(64, 48));
    EXPECT_GE(after.near_objects.size(), 2u);
  }
}

TEST(SynthMotion, FastSceneReachesNinetyDegreesPerSecond) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  auto peak_rate = [&](SceneKind kind) {
    const CameraMotion motion(kind, 4);
    double peak = 0;
    for (double t = 0; t < 12.0; t += 0.005)
      peak = std::max(peak, true_gyro(motion, identity, t).norm());
    return peak / kDeg;
  };
  const double fast = peak_rate(SceneKind::kFast);
  EXPECT_GT(fast, 80.0);
  EXPECT_LT(fast, 140.0);
  EXPECT_LT(peak_rate(SceneKind::kRoom), 50.0);
}

}  // namespace
}  // namespace imufusion::synth
