// Relocalization's translation search over the model's distance field, the drift correction of
// a lost stretch, and the surface points of a TSDF snapshot.

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/relocalizer.hpp"

namespace imufusion {
namespace {

// Samples of the inside of a 4 x 3 x 2.5 m box (floor, walls) with a 0.5 m cube on the floor
// off-centre: enough structure to fix a translation in all three directions.
std::vector<Eigen::Vector3d> room_surface(double step) {
  std::vector<Eigen::Vector3d> points;
  const Eigen::Vector3d size(4.0, 3.0, 2.5);
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (double a = 0; a <= size[u]; a += step)
      for (double b = 0; b <= size[v]; b += step)
        for (double side : {0.0, size[axis]}) {
          if (axis == 2 && side > 0) continue;  // no ceiling
          Eigen::Vector3d p;
          p[axis] = side;
          p[u] = a;
          p[v] = b;
          points.push_back(p);
        }
  }
  const Eigen::Vector3d lo(2.6, 0.7, 0.0);
  for (double a = 0; a <= 0.5; a += step)
    for (double b = 0; b <= 0.5; b += step) {
      points.push_back(lo + Eigen::Vector3d(a, b, 0.5));
      points.push_back(lo + Eigen::Vector3d(0.0, a, b));
      points.push_back(lo + Eigen::Vector3d(0.5, a, b));
      points.push_back(lo + Eigen::Vector3d(a, 0.0, b));
      points.push_back(lo + Eigen::Vector3d(a, 0.5, b));
    }
  return points;
}

Eigen::Isometry3d camera_pose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-1.9, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(1.1, 1.3, 1.4);
  return T;
}

// The surface points a camera at T would see within 4 m in front of it (a crude frame).
std::vector<Eigen::Vector3d> frame_points(const std::vector<Eigen::Vector3d>& surface, const Eigen::Isometry3d& T,
                                          std::size_t stride) {
  std::vector<Eigen::Vector3d> out;
  const Eigen::Isometry3d inv = T.inverse();
  for (std::size_t i = 0; i < surface.size(); i += stride) {
    const Eigen::Vector3d p = inv * surface[i];
    if (p.z() > 0.4 && p.z() < 4.0 && std::abs(p.x()) < 0.6 * p.z() && std::abs(p.y()) < 0.45 * p.z())
      out.push_back(p);
  }
  return out;
}

TEST(SurfaceDistanceField, DistanceToAPlaneWithinACellAndCutOffBeyond) {
  std::vector<Eigen::Vector3d> plane;
  for (double x = -1; x <= 1; x += 0.01)
    for (double y = -1; y <= 1; y += 0.01) plane.emplace_back(x, y, 0.0);
  const SurfaceDistanceField field(plane, 0.05, 0.2);
  ASSERT_FALSE(field.empty());
  for (double z : {0.0, 0.05, 0.1, 0.15}) EXPECT_NEAR(field.distance({0.2, -0.3, z}), z, 0.05) << z;
  EXPECT_DOUBLE_EQ(field.distance({0.2, -0.3, 0.5}), 0.2);
  EXPECT_DOUBLE_EQ(field.distance({5.0, 0.0, 0.0}), 0.2);
  EXPECT_DOUBLE_EQ(field.distance({0.0, 0.0, std::nan("")}), 0.2);
}

TEST(SurfaceDistanceField, EmptyInputsGiveNoCandidates) {
  const SurfaceDistanceField none({}, 0.05, 0.2);
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(none.search({{0, 0, 1}}, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1.0, 3).empty());
  const SurfaceDistanceField field(room_surface(0.05), 0.05, 0.2);
  EXPECT_TRUE(field.search({}, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1.0, 3).empty());
}

// A frame dead-reckoned 0.7 m off: the best candidate is the true position to within a cell.
TEST(SurfaceDistanceField, SearchFindsTheTranslationOfAStructuredView) {
  const std::vector<Eigen::Vector3d> surface = room_surface(0.02);
  const SurfaceDistanceField field(surface, 0.05, 0.2);
  const Eigen::Isometry3d T = camera_pose();
  std::vector<Eigen::Vector3d> points = frame_points(surface, T, 7);
  ASSERT_GT(points.size(), 300u);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  for (Eigen::Vector3d& p : points) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  const Eigen::Vector3d drift(0.45, -0.4, 0.35);
  const auto candidates = field.search(points, T.linear(), T.translation() + drift, 0.8, 3);
  ASSERT_FALSE(candidates.empty());
  EXPECT_LT((candidates[0].translation - T.translation()).norm(), 0.05);
  EXPECT_GT(candidates[0].near_fraction, 0.9);
  for (std::size_t i = 1; i < candidates.size(); ++i) {
    EXPECT_GE(candidates[i].cost, candidates[i - 1].cost);
    EXPECT_GE((candidates[i].translation - candidates[0].translation).cwiseAbs().maxCoeff(), 0.1 - 1e-9);
  }
  // Out of reach: searched within 0.3 m of a position 0.7 m off, the true one is not offered.
  const auto near = field.search(points, T.linear(), T.translation() + drift, 0.3, 3);
  for (const auto& c : near) EXPECT_GT((c.translation - T.translation()).norm(), 0.3);
}

TEST(DriftCorrection, MatchesTheEndsAndFollowsEachErrorSource) {
  const double T = 4.0;
  const Eigen::Vector3d g(0.0, 0.0, -9.81);
  DriftPrior prior;
  prior.gravity_world = g;
  prior.velocity_sigma = 0.02;
  prior.accel_bias_sigma = 0.05;
  const Eigen::Vector3d rotation(0.01, -0.03, 0.02), translation(0.3, -0.2, 0.1);
  EXPECT_LT(drift_correction(0.0, T, translation, rotation, prior).norm(), 1e-12);
  EXPECT_LT((drift_correction(T, T, translation, rotation, prior) - translation).norm(), 1e-12);
  EXPECT_LT((drift_correction(9.0, T, translation, rotation, prior) - translation).norm(), 1e-12);

  // A tilt error alone: the correction is the double integral of -(delta(s) x g), delta linear.
  const Eigen::Vector3d tilt_end = -rotation.cross(g) * T * T / 6.0;
  for (double u : {0.25, 0.5, 0.75}) {
    const Eigen::Vector3d c = drift_correction(u * T, T, tilt_end, rotation, prior);
    EXPECT_LT((c - tilt_end * u * u * u).norm(), 1e-12) << u;
  }
  // No rotation error: a velocity error alone is linear, a bias error alone quadratic.
  DriftPrior velocity_only;
  velocity_only.gravity_world = g;
  velocity_only.velocity_sigma = 0.02;
  DriftPrior bias_only;
  bias_only.accel_bias_sigma = 0.05;
  for (double u : {0.25, 0.5, 0.75}) {
    EXPECT_LT((drift_correction(u * T, T, translation, Eigen::Vector3d::Zero(), velocity_only) - u * translation).norm(), 1e-12);
    EXPECT_LT((drift_correction(u * T, T, translation, Eigen::Vector3d::Zero(), bias_only) - u * u * translation).norm(), 1e-12);
    // With both, in between.
    const double share = drift_correction(u * T, T, translation, Eigen::Vector3d::Zero(), prior).dot(translation) /
                         translation.squaredNorm();
    EXPECT_GT(share, u * u);
    EXPECT_LT(share, u);
  }
  // Rotation about gravity tilts nothing.
  EXPECT_LT((drift_correction(0.5 * T, T, translation, Eigen::Vector3d(0, 0, 0.05), velocity_only) - 0.5 * translation).norm(), 1e-12);
}

TEST(VolumeSurfacePoints, TakesObservedVoxelsNearTheZeroCrossing) {
  HostVolume volume;
  volume.voxel_size = 0.01f;
  VolumeBlock block;
  block.coord = Eigen::Vector3i(2, -1, 0);
  for (int k = 0; k < kBlockSide; ++k)
    for (int j = 0; j < kBlockSide; ++j)
      for (int i = 0; i < kBlockSide; ++i) {
        Voxel& v = block.voxels[static_cast<std::size_t>(voxel_index(i, j, k))];
        v.tsdf = 0.3f * static_cast<float>(k - 4);  // zero crossing at k = 4
        v.weight = j == 7 ? 0.0f : 5.0f;             // one row never observed
      }
  volume.blocks.push_back(block);
  const auto points = volume_surface_points(volume);
  ASSERT_EQ(points.size(), 3u * 8u * 7u);  // k = 3, 4, 5 (|tsdf| < 0.5), j != 7
  for (const Eigen::Vector3d& p : points) {
    EXPECT_GE(p.z(), 0.03 - 1e-6);
    EXPECT_LE(p.z(), 0.05 + 1e-6);
    EXPECT_GE(p.x(), 0.16 - 1e-6);
    EXPECT_LT(p.y(), -0.08 + 0.07 + 1e-6);
  }
}

}  // namespace
}  // namespace imufusion
