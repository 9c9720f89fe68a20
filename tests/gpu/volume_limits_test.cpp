// The GPU sparse TSDF volume at its limits: long probe chains, a full block pool, a full hash
// table and blocks out of the key range. Nothing may hang, no more blocks than the capacity, the
// blocks that got storage hold what the reference computes for them, and every block a frame
// touched is reported as fused or refused (tolerances: volume_test.cpp).

#include <gtest/gtest.h>

#include "imufusion/reconstructor.hpp"
#include "volume_test_support.hpp"

namespace imufusion {
namespace {

using namespace volume_test;

std::size_t home_slot_collisions(const Blocks& blocks, std::uint32_t hash_slots) {
  std::vector<int> load(hash_slots, 0);
  for (const Eigen::Vector3i& b : blocks) {
    const std::uint32_t h = (static_cast<std::uint32_t>(b.x()) * 73856093u) ^
                            (static_cast<std::uint32_t>(b.y()) * 19349669u) ^
                            (static_cast<std::uint32_t>(b.z()) * 83492791u);
    ++load[h & (hash_slots - 1)];
  }
  std::size_t colliding = 0;
  for (int n : load) colliding += n > 1 ? static_cast<std::size_t>(n) : 0;
  return colliding;
}

// A small sphere alone: a few dozen blocks.
synth::Scene small_sphere_scene() {
  synth::Scene scene;
  synth::Sphere sphere;
  sphere.center = Eigen::Vector3d(0.1, 0.0, 0.2);
  sphere.radius = 0.16;
  scene.spheres.push_back(sphere);
  return scene;
}

TEST_F(GpuTest, VolumeLongProbeChainsStillFindEveryBlock) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = config.hash_slots = 64;  // every block collides with its neighbours
  const synth::Scene scene = small_sphere_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  for (double angle : {0.0, 0.1}) {
    const Frame frame = make_frame(scene, orbit_pose(angle), k, true);
    const IntegrationStats stats = gpu.integrate(frame);
    ref.fuse(frame.depth, &frame.color, k, frame.T_world_camera);
    EXPECT_EQ(stats.pool_full + stats.table_full + stats.out_of_range, 0u);
    EXPECT_EQ(stats.allocated_blocks, ref.block_count());
  }
  const Blocks ref_blocks = ref.block_coords();
  ASSERT_GT(ref_blocks.size(), 40u) << "the table must be mostly full";
  ASSERT_LE(ref_blocks.size(), 64u) << "the blocks must fit";
  EXPECT_GT(home_slot_collisions(ref_blocks, config.hash_slots), ref_blocks.size() / 3);
  const HostVolume host = gpu.snapshot();
  EXPECT_EQ(host.blocks.size(), gpu.volume.allocated_blocks());
  EXPECT_EQ(symmetric_difference(sorted_blocks(host), ref_blocks), 0u);
  const VoxelDiff diff = compare_voxels(host, ref);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
  // Lookups through the long chains: the raycast finds the surface.
  const RaycastImages view = gpu.raycast(k, orbit_pose(0.05), 0.3f, 3.0f);
  const std::size_t hits =
      static_cast<std::size_t>(std::count_if(view.vertices.data.begin(), view.vertices.data.end(),
                                             [](const Eigen::Vector4f& v) { return v.w() > 0; }));
  EXPECT_GT(hits, 100u);
}

// Checks a volume whose pool or table overflowed: capacity respected, the stored blocks are
// blocks the frames touched, and each holds what the reference computes for it.
void expect_stored_blocks_correct(GpuVolume& gpu, const VolumeConfig& config,
                                  const std::vector<Frame>& frames, const Intrinsics& k) {
  const HostVolume host = gpu.snapshot();
  const Blocks stored = sorted_blocks(host);
  EXPECT_EQ(stored.size(), config.block_capacity);
  EXPECT_FALSE(has_duplicates(stored));
  CpuVolume all(config);
  for (const Frame& frame : frames) all.allocate(frame.depth, k, frame.T_world_camera);
  Blocks outside;
  const Blocks touched = all.block_coords();
  std::set_difference(stored.begin(), stored.end(), touched.begin(), touched.end(),
                      std::back_inserter(outside), reference::block_less);
  EXPECT_LE(outside.size(), 1u) << "stored blocks that no frame touched";
  const VoxelDiff diff = compare_voxels(host, reference_on_blocks(config, stored, frames, k));
  ASSERT_GT(diff.observed, 5000u);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
}

// A frame's report: of the blocks it touched (the reference's visible set), those with storage
// are fused (visible_blocks) and the others counted in pool_full, up to the allocation budget.
void expect_touched_blocks_reported(const IntegrationStats& stats, GpuVolume& gpu,
                                    const VolumeConfig& config, const Frame& frame,
                                    const Intrinsics& k) {
  const Blocks touched = reference::visible_blocks(frame.depth, k, frame.T_world_camera,
                                                   config.voxel_size, config.truncation())
                             .visible;
  const Blocks stored = sorted_blocks(gpu.snapshot());
  Blocks fused;
  std::set_intersection(touched.begin(), touched.end(), stored.begin(), stored.end(),
                        std::back_inserter(fused), reference::block_less);
  EXPECT_NEAR(double(stats.visible_blocks), double(fused.size()), budget(touched.size()));
  EXPECT_NEAR(double(stats.pool_full), double(touched.size() - fused.size()),
              budget(touched.size()));
}

// A pool that starts at the capacity, and one that starts below it and grows to it in the first
// frame: at the capacity both report alike.
TEST_F(GpuTest, VolumeFullPoolReportsAndKeepsStoredBlocksCorrect) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = 64;  // the objects need hundreds
  config.hash_slots = 16384;   // keys of blocks refused storage stay in the table: room for all
  const synth::Scene scene = objects_scene();
  for (const std::uint32_t initial : {64u, 8u}) {
    config.initial_blocks = initial;
    auto gpu_volume = GpuVolume::create(context_, config, k);
    ASSERT_TRUE(gpu_volume.has_value());
    GpuVolume& gpu = *gpu_volume;
    std::vector<Frame> frames;
    // The same view twice, then another. Blocks refused storage keep their key in the table
    // (with no pool index); seen again they are refused again, and must not take the place of
    // blocks that have storage.
    for (double angle : {0.0, 0.0, 0.2}) {
      frames.push_back(make_frame(scene, orbit_pose(angle), k, true));
      const IntegrationStats stats = gpu.integrate(frames.back());
      EXPECT_EQ(stats.table_full, 0u);
      EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
      EXPECT_EQ(gpu.volume.pool_blocks(), config.block_capacity) << "initial " << initial;
      expect_touched_blocks_reported(stats, gpu, config, frames.back(), k);
      expect_stored_blocks_correct(gpu, config, frames, k);
    }
  }
}

// The frame that fills the pool: thousands of insertions race for 256 pool blocks. Every stored
// block was touched by this first frame, so all of them must be fused, none pushed off the
// visible list by a refused block, and every refused block reported; alike when the pool starts
// smaller and the frame, deferred, is fused again once the pool has grown to the capacity.
TEST_F(GpuTest, VolumeFrameThatFillsThePoolFusesEveryStoredBlock) {
  const Intrinsics k = synth::default_intrinsics(320, 240);
  VolumeConfig config = small_config();
  config.block_capacity = 256;
  const synth::Scene scene = objects_scene();
  for (double angle : {0.0, 0.7, 1.4}) {
    config.initial_blocks = angle == 0.7 ? 256 : 40;
    auto gpu_volume = GpuVolume::create(context_, config, k);
    ASSERT_TRUE(gpu_volume.has_value());
    GpuVolume& gpu = *gpu_volume;
    const std::vector<Frame> frames{make_frame(scene, orbit_pose(angle), k, true)};
    const IntegrationStats stats = gpu.integrate(frames.back());
    EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
    EXPECT_EQ(stats.visible_blocks, config.block_capacity) << "angle " << angle;
    EXPECT_GT(stats.pool_full, config.block_capacity) << "the frame needs several times the pool";
    expect_touched_blocks_reported(stats, gpu, config, frames.back(), k);
    expect_stored_blocks_correct(gpu, config, frames, k);
  }
}

TEST_F(GpuTest, VolumeFullTableReportsWithoutHanging) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = config.hash_slots = 64;  // every slot ends up used
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  std::vector<Frame> frames;
  for (double angle : {0.0, 0.3}) {
    frames.push_back(make_frame(scene, orbit_pose(angle), k, false));
    const IntegrationStats stats = gpu.integrate(frames.back());
    EXPECT_GT(stats.table_full, 0u);
    EXPECT_EQ(stats.pool_full, 0u) << "as many slots as pool blocks: the pool cannot overflow";
    EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
    expect_stored_blocks_correct(gpu, config, frames, k);
  }
  // Lookups of absent blocks probe the whole full table and give up.
  const RaycastImages view = gpu.raycast(k, orbit_pose(0.1), 0.3f, 3.0f);
  EXPECT_EQ(view.vertices.data.size(), static_cast<std::size_t>(k.width * k.height));
}

TEST_F(GpuTest, VolumeOutOfRangeBlocksAreCountedAndNotFused) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  synth::Scene scene = objects_scene();
  // A wall across the edge of the key range: blocks x = 1023 (in) and 1024 (out), at 81.9 m.
  synth::Plane wall;
  wall.normal = Eigen::Vector3d::UnitX();
  wall.offset = 81.9;
  scene.planes.push_back(wall);
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  const Frame home = make_frame(scene, orbit_pose(0.0), k, true);
  gpu.integrate(home);
  ref.fuse(home.depth, &home.color, k, home.T_world_camera);
  const HostVolume before = gpu.snapshot();

  // 100 km away, looking at the same objects moved with it: every block is out of range.
  Eigen::Isometry3d far_pose = orbit_pose(0.0);
  far_pose.translation() += Eigen::Vector3d(1.0e5, 0.0, 0.0);
  const Frame far_frame{home.depth, home.color, far_pose};
  const IntegrationStats far_stats = gpu.integrate(far_frame);
  EXPECT_GT(far_stats.out_of_range, 0u);
  EXPECT_EQ(far_stats.visible_blocks, 0u);
  EXPECT_EQ(far_stats.allocated_blocks, before.blocks.size());
  const VoxelDiff unchanged =
      compare_voxels(gpu.snapshot(), CpuVolume::from_host_volume(before, 64));
  EXPECT_EQ(unchanged.outliers, 0u) << unchanged;
  EXPECT_EQ(ref.fuse(far_frame.depth, &far_frame.color, k, far_pose).visible.size(), 0u);

  // Half in, half out of range: the in-range half is fused like the reference does.
  const Frame edge = make_frame(
      scene, look_at(Eigen::Vector3d(80.9, 0.05, 0.1), Eigen::Vector3d(81.9, 0.05, 0.1)), k, true);
  const IntegrationStats edge_stats = gpu.integrate(edge);
  const auto edge_ref = ref.fuse(edge.depth, &edge.color, k, edge.T_world_camera);
  EXPECT_GT(edge_ref.out_of_range, 0u);
  EXPECT_GT(edge_ref.visible.size(), 0u);
  EXPECT_NEAR(double(edge_stats.out_of_range), double(edge_ref.out_of_range),
              budget(edge_ref.out_of_range));
  EXPECT_EQ(edge_stats.pool_full + edge_stats.table_full, 0u);
  const VoxelDiff diff = compare_voxels(gpu.snapshot(), ref);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
}

// The last block of the key range, (1023, 1023, 511), would pack to the bits of the empty-slot
// marker, so it counts as out of range. Before it did, every ray through it took a new pool
// block (none of them findable): allocated_blocks grew past the blocks in the table.
TEST_F(GpuTest, VolumeLastKeyOfTheRangeIsNotAllocated) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  const double edge = 1024 * kBlockSide * config.voxel_size;   // 81.92 m: first x, y out
  const double edge_z = 512 * kBlockSide * config.voxel_size;  // 40.96 m: first z out
  synth::Scene scene;
  synth::Plane wall;
  wall.normal = Eigen::Vector3d::UnitX();
  wall.offset = edge - 0.03;
  scene.planes.push_back(wall);
  // A point of the wall inside block (1023, 1023, 511), seen by the centre pixel.
  const Eigen::Vector3d corner(edge - 0.03, edge - 0.04, edge_z - 0.04);
  const Eigen::Vector3i last_key(1023, 1023, 511);
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  for (double dx : {1.0, 0.8}) {
    const Frame frame =
        make_frame(scene, look_at(corner - Eigen::Vector3d(dx, 0.0, 0.0), corner), k, true);
    ASSERT_GT(frame.depth.at(k.width / 2, k.height / 2), 0.0f);
    const IntegrationStats stats = gpu.integrate(frame);
    ref.fuse(frame.depth, &frame.color, k, frame.T_world_camera);
    ASSERT_TRUE(ref.contains(Eigen::Vector3i(1023, 1022, 511)));
    ASSERT_TRUE(ref.contains(Eigen::Vector3i(1023, 1023, 510)));
    EXPECT_FALSE(ref.contains(last_key));
    EXPECT_GT(stats.out_of_range, 0u);
    EXPECT_EQ(stats.allocated_blocks, ref.block_count());
    const HostVolume host = gpu.snapshot();
    EXPECT_EQ(host.blocks.size(), stats.allocated_blocks);
    EXPECT_EQ(symmetric_difference(sorted_blocks(host), ref.block_coords()), 0u);
    const VoxelDiff diff = compare_voxels(host, ref);
    EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
  }
}

TEST_F(GpuTest, VolumeMemoryIsEightBytesPerVoxel) {
  VolumeConfig config = small_config();
  config.block_capacity = 96;
  config.hash_slots = 256;
  for (const std::uint32_t initial : {32u, 96u, 1000u}) {
    config.initial_blocks = initial;
    ReconstructorConfig scanner;
    scanner.intrinsics = synth::default_intrinsics(97, 61);
    scanner.volume = config;
    auto fusion = Reconstructor::create(scanner);
    ASSERT_TRUE(fusion.ok()) << fusion.error().describe();
    // Pool: two 32-bit words per voxel of the blocks it holds now (at most the capacity), and
    // the hash slot of each block up to the capacity. Table: key, value and visibility stamp per
    // slot. Visible list: one entry per slot.
    const std::uint32_t held = std::min(initial, config.block_capacity);
    EXPECT_EQ(fusion->pool_blocks(), held);
    const std::uint64_t pool =
        std::uint64_t{held} * kBlockVoxels * 8 + std::uint64_t{config.block_capacity} * 4;
    const std::uint64_t table = std::uint64_t{config.hash_slots} * 3 * 4;
    const std::uint64_t visible = std::uint64_t{config.hash_slots} * 4;
    EXPECT_EQ(fusion->memory_bytes(), pool + table + visible);
    EXPECT_EQ(fusion->validation_error_count(), 0u);
  }
}

}  // namespace
}  // namespace imufusion
