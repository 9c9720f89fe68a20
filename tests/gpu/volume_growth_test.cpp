// The block pool that grows: a volume whose pool starts far below what the frames need holds,
// voxel for voxel, what one sized for them from the start holds (frames that overflowed it are
// fused again after it grew), and reserve_blocks() keeps every block and stops at the capacity.
// A scan through the Reconstructor gives the same trajectory either way.

#include <gtest/gtest.h>

#include <map>
#include <tuple>

#include "reconstructor_test_support.hpp"
#include "volume_test_support.hpp"

namespace imufusion {
namespace {

using namespace volume_test;

// Blocks by coordinate, for an exact comparison of two snapshots.
std::map<std::tuple<int, int, int>, const VolumeBlock*> by_coord(const HostVolume& host) {
  std::map<std::tuple<int, int, int>, const VolumeBlock*> blocks;
  for (const VolumeBlock& b : host.blocks) blocks[{b.coord.x(), b.coord.y(), b.coord.z()}] = &b;
  return blocks;
}

// Voxels of the same blocks that differ in TSDF, weight or colour (bit for bit), plus the blocks
// that only one of the two holds.
std::size_t voxel_differences(const HostVolume& a, const HostVolume& b) {
  const auto blocks_a = by_coord(a), blocks_b = by_coord(b);
  std::size_t differences = 0;
  for (const auto& [coord, block] : blocks_a) {
    const auto other = blocks_b.find(coord);
    if (other == blocks_b.end()) {
      ++differences;
      continue;
    }
    for (std::size_t v = 0; v < kBlockVoxels; ++v) {
      const Voxel &x = block->voxels[v], &y = other->second->voxels[v];
      differences += (x.tsdf != y.tsdf || x.weight != y.weight || x.color != y.color) ? 1 : 0;
    }
  }
  for (const auto& [coord, block] : blocks_b) differences += blocks_a.count(coord) == 0 ? 1 : 0;
  return differences;
}

std::size_t pixel_differences(const RaycastImages& a, const RaycastImages& b) {
  std::size_t differences = 0;
  for (std::size_t i = 0; i < a.vertices.data.size(); ++i) {
    differences += (a.vertices.data[i] != b.vertices.data[i] ||
                    a.normals.data[i] != b.normals.data[i] || a.color.data[i] != b.color.data[i])
                       ? 1
                       : 0;
  }
  return differences;
}

TEST_F(GpuTest, VolumePoolThatGrowsHoldsWhatALargeOneHolds) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig large = small_config();
  large.initial_blocks = large.block_capacity;
  VolumeConfig small = large;
  small.initial_blocks = 16;  // the first frame alone needs hundreds: it is fused again
  const synth::Scene scene = objects_scene();
  auto grown = GpuVolume::create(context_, small, k);
  auto sized = GpuVolume::create(context_, large, k);
  ASSERT_TRUE(grown.has_value() && sized.has_value());
  EXPECT_EQ(grown->volume.pool_blocks(), 16u);
  for (double angle : {0.0, 0.4, 0.8, 1.6, 2.4, 3.2}) {
    const auto frame = make_frame(scene, orbit_pose(angle), k, true);
    const IntegrationStats a = grown->integrate(frame), b = sized->integrate(frame);
    EXPECT_EQ(a.pool_full + a.table_full + a.out_of_range, 0u) << "angle " << angle;
    EXPECT_EQ(a.visible_blocks, b.visible_blocks) << "angle " << angle;
    EXPECT_EQ(a.allocated_blocks, b.allocated_blocks) << "angle " << angle;
    EXPECT_GE(grown->volume.pool_blocks(), a.allocated_blocks);
  }
  EXPECT_GE(grown->volume.pool_growths(), 2u);
  EXPECT_LT(grown->volume.pool_blocks(), large.block_capacity);
  EXPECT_EQ(grown->volume.reserved_bytes(), small.reserved_bytes(grown->volume.pool_blocks()));
  const HostVolume a = grown->snapshot(), b = sized->snapshot();
  ASSERT_GT(a.blocks.size(), 200u);
  EXPECT_EQ(voxel_differences(a, b), 0u);
  const RaycastImages view_a = grown->raycast(k, orbit_pose(1.0), 0.3f, 3.0f);
  const RaycastImages view_b = sized->raycast(k, orbit_pose(1.0), 0.3f, 3.0f);
  EXPECT_EQ(pixel_differences(view_a, view_b), 0u);
}

TEST_F(GpuTest, VolumeReserveBlocksKeepsTheBlocksAndStopsAtTheCapacity) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.initial_blocks = 600;
  auto gpu = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu.has_value());
  const synth::Scene scene = objects_scene();
  std::vector<volume_test::Frame> frames{make_frame(scene, orbit_pose(0.0), k, true)};
  gpu->integrate(frames.back());
  const std::uint32_t held = gpu->volume.pool_blocks();
  const HostVolume before = gpu->snapshot();
  ASSERT_GT(before.blocks.size(), 100u);

  EXPECT_TRUE(gpu->volume.reserve_blocks(held / 2).ok());  // holds them already
  EXPECT_EQ(gpu->volume.pool_blocks(), held);
  const Status beyond = gpu->volume.reserve_blocks(config.block_capacity + 1);
  ASSERT_FALSE(beyond.ok());
  EXPECT_NE(beyond.error().message.find("block_capacity is 8192"), std::string::npos)
      << beyond.error().message;
  EXPECT_EQ(gpu->volume.pool_blocks(), held);
  ASSERT_TRUE(gpu->volume.reserve_blocks(held + 1000).ok());
  EXPECT_EQ(gpu->volume.pool_blocks(), held + 1000);
  EXPECT_EQ(voxel_differences(gpu->snapshot(), before), 0u);

  // Fusion goes on in the larger pool as the reference computes it.
  frames.push_back(make_frame(scene, orbit_pose(0.5), k, true));
  const IntegrationStats stats = gpu->integrate(frames.back());
  EXPECT_EQ(stats.pool_full + stats.table_full, 0u);
  const HostVolume after = gpu->snapshot();
  const VoxelDiff diff =
      compare_voxels(after, reference_on_blocks(config, sorted_blocks(after), frames, k));
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
  ASSERT_TRUE(gpu->volume.reserve_blocks(config.block_capacity).ok());
  EXPECT_EQ(gpu->volume.pool_blocks(), config.block_capacity);
}

using ScanTest = test::ReconstructorTest;

// The room's scan with a pool of 64 blocks at first (it needs thousands): the pool grows while
// frames are tracked, and the trajectory and the volume are those of a pool sized from the start.
TEST_F(ScanTest, APoolThatGrowsGivesTheSameScanAsALargeOne) {
  ReconstructorConfig large = config(true, 2);
  large.volume.block_capacity = 1u << 14;  // the scan needs about half
  large.volume.hash_slots = 1u << 16;
  large.volume.initial_blocks = large.volume.block_capacity;
  ReconstructorConfig small = large;
  small.volume.initial_blocks = 64;
  Reconstructor grown = make(small), sized = make(large);
  EXPECT_EQ(grown.pool_blocks(), 64u);
  for (const auto& f : frames_) {
    const ColorImage* color = f.color ? &*f.color : nullptr;
    auto a = grown.track_and_fuse(f.timestamp, f.depth, color, f.imu);
    auto b = sized.track_and_fuse(f.timestamp, f.depth, color, f.imu);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->integration.pool_full, 0u);
    EXPECT_EQ(a->integration.visible_blocks, b->integration.visible_blocks);
    EXPECT_TRUE(a->T_world_camera.matrix() == b->T_world_camera.matrix()) << "frame " << a->index;
  }
  EXPECT_EQ(grown.allocated_blocks(), sized.allocated_blocks());
  EXPECT_GT(grown.pool_blocks(), 64u);
  EXPECT_LT(grown.pool_blocks(), large.volume.block_capacity);
  EXPECT_LT(grown.memory_bytes(), sized.memory_bytes());
  auto a = grown.snapshot();
  auto b = sized.snapshot();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(voxel_differences(*a, *b), 0u);
  EXPECT_EQ(grown.validation_error_count(), 0u);
}

}  // namespace
}  // namespace imufusion
