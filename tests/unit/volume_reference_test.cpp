// The CPU reference of the TSDF volume on its own (no GPU): a fronto-parallel plane fused from
// its own viewpoint has the expected signed distances at the lattice points, the blocks of the
// band, and a raycast that finds the plane at its depth with the normal facing the camera.

#include "reference/volume_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace imufusion {
namespace {

constexpr double kVoxel = 0.01;       // metres
constexpr double kTruncation = 0.04;  // metres
constexpr double kPlaneZ = 1.0;       // metres, camera frame = world frame

Intrinsics small_intrinsics() {
  Intrinsics k;
  k.width = 41;
  k.height = 29;
  k.fx = k.fy = 40.0;
  k.cx = 20.3;
  k.cy = 13.8;
  return k;
}

FloatImage plane_depth(const Intrinsics& k, double z) {
  FloatImage depth;
  depth.width = k.width;
  depth.height = k.height;
  depth.data.assign(static_cast<std::size_t>(k.width * k.height), static_cast<float>(z));
  return depth;
}

TEST(VolumeReference, PlaneAllocatesTheBlocksOfItsBand) {
  const Intrinsics k = small_intrinsics();
  const auto result = reference::visible_blocks(plane_depth(k, kPlaneZ), k,
                                                Eigen::Isometry3d::Identity(), kVoxel, kTruncation);
  ASSERT_FALSE(result.visible.empty());
  EXPECT_EQ(result.out_of_range, 0u);
  // The band [0.96, 1.04] m lies in blocks z = 12 (0.96..1.04) and z = 13 (1.04..1.12).
  bool saw12 = false, saw13 = false;
  for (const Eigen::Vector3i& b : result.visible) {
    EXPECT_TRUE(b.z() == 12 || b.z() == 13) << b.transpose();
    saw12 = saw12 || b.z() == 12;
    saw13 = saw13 || b.z() == 13;
  }
  EXPECT_TRUE(saw12 && saw13);
}

TEST(VolumeReference, PlaneTsdfIsZeroOnThePlaneAndPositiveInFront) {
  const Intrinsics k = small_intrinsics();
  reference::CpuVolume volume(kVoxel, kTruncation, 10);
  const FloatImage depth = plane_depth(k, kPlaneZ);
  for (int frame = 0; frame < 3; ++frame)
    volume.fuse(depth, nullptr, k, Eigen::Isometry3d::Identity());

  // The lattice points on the optical axis: x = y = 0, z = l * 1 cm.
  const int plane_l = static_cast<int>(std::lround(kPlaneZ / kVoxel));
  for (int dl = -4; dl <= 8; ++dl) {  // blocks z = 12, 13 hold l = 96..111
    const reference::StoredVoxel* voxel = volume.voxel(Eigen::Vector3i(0, 0, plane_l + dl));
    ASSERT_NE(voxel, nullptr) << dl;
    const double sdf = -dl * kVoxel;  // metres, positive in front of the plane
    if (std::abs(std::abs(sdf) - kTruncation) < 1e-9) continue;  // on the band's edge: rounding
    if (sdf < -kTruncation - 1e-9) {
      EXPECT_EQ(voxel->weight, 0) << "behind the band, dl = " << dl;
      continue;
    }
    EXPECT_EQ(voxel->weight, 3) << dl;
    const double expected = std::min(1.0, sdf / kTruncation);
    EXPECT_NEAR(voxel->tsdf / 32767.0, expected, 1e-4) << dl;
    if (dl < 0) {
      EXPECT_GT(voxel->tsdf, 0) << dl;
    }
  }
  // Every observed lattice point of the plane itself has tsdf ~ 0.
  int on_plane = 0;
  for (int y = -12; y <= 12; ++y) {
    for (int x = -20; x <= 20; ++x) {
      const reference::StoredVoxel* voxel = volume.voxel(Eigen::Vector3i(x, y, plane_l));
      if (voxel == nullptr || voxel->weight == 0) continue;
      ++on_plane;
      EXPECT_LE(std::abs(voxel->tsdf), 4) << x << " " << y;  // 4 / 32767 truncation units
    }
  }
  EXPECT_GT(on_plane, 300);
}

TEST(VolumeReference, RaycastHitsThePlaneAtItsDepth) {
  const Intrinsics k = small_intrinsics();
  reference::CpuVolume volume(kVoxel, kTruncation, 10);
  volume.fuse(plane_depth(k, kPlaneZ), nullptr, k, Eigen::Isometry3d::Identity());

  // From a pose moved 5 cm sideways and 10 cm back, slightly turned: the plane is still
  // z = 1 m in the world; a narrower view keeps the rays on the fused part.
  Intrinsics narrow = k;
  narrow.fx = narrow.fy = 80.0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  T_world_camera.translation() = Eigen::Vector3d(0.05, 0.0, -0.1);
  T_world_camera.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const RaycastImages ray = volume.raycast(narrow, T_world_camera, 0.3, 3.0);
  int hits = 0;
  for (std::size_t i = 0; i < ray.vertices.data.size(); ++i) {
    if (ray.vertices.data[i].w() == 0.0f) continue;
    ++hits;
    const Eigen::Vector3d vertex = ray.vertices.data[i].head<3>().cast<double>();
    const Eigen::Vector3d world = T_world_camera * vertex;
    EXPECT_NEAR(world.z(), kPlaneZ, 2e-4) << i;  // linear TSDF: the refinement is exact
    ASSERT_EQ(ray.normals.data[i].w(), 1.0f);
    const Eigen::Vector3d normal_world =
        T_world_camera.linear() * ray.normals.data[i].head<3>().cast<double>();
    EXPECT_NEAR(normal_world.z(), -1.0, 1e-3) << i;  // faces the camera
  }
  EXPECT_GT(hits, static_cast<int>(ray.vertices.data.size()) * 9 / 10);
}

TEST(VolumeReference, HostVolumeRoundTripIsLossless) {
  const Intrinsics k = small_intrinsics();
  reference::CpuVolume volume(kVoxel, kTruncation, 10);
  ColorImage color;
  color.width = k.width;
  color.height = k.height;
  color.data.resize(static_cast<std::size_t>(3 * k.width * k.height));
  for (std::size_t i = 0; i < color.data.size(); ++i)
    color.data[i] = static_cast<std::uint8_t>(i * 7);
  volume.fuse(plane_depth(k, 0.93), &color, k, Eigen::Isometry3d::Identity());
  volume.fuse(plane_depth(k, 0.95), &color, k, Eigen::Isometry3d::Identity());
  const HostVolume host = volume.to_host_volume();
  const auto copy = reference::CpuVolume::from_host_volume(host, 10);
  ASSERT_EQ(copy.block_count(), volume.block_count());
  for (const Eigen::Vector3i& b : volume.block_coords()) {
    for (int i = 0; i < kBlockVoxels; ++i) {
      const Eigen::Vector3i l = 8 * b + Eigen::Vector3i(i % 8, (i / 8) % 8, i / 64);
      const reference::StoredVoxel* a = volume.voxel(l);
      const reference::StoredVoxel* c = copy.voxel(l);
      ASSERT_NE(c, nullptr);
      EXPECT_EQ(a->tsdf, c->tsdf);
      EXPECT_EQ(a->weight, c->weight);
      EXPECT_EQ(a->color, c->color);
    }
  }
}

}  // namespace
}  // namespace imufusion
