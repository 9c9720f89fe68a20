#pragma once
// The sparse TSDF block volume on the GPU: hash table, block pool, allocation, integration,
// raycast, and the download of a host snapshot. The pool starts at VolumeConfig::initial_blocks
// and grows on the device (the blocks copied into larger buffers) up to block_capacity: ahead of
// need by the most blocks one frame has added to a non-empty volume so far, and when a frame
// still overflows it, that frame fuses nothing, the pool grows and the frame is recorded again.
// The hash table keeps its size: hash_slots >= block_capacity bounds its load factor.

#include <algorithm>
#include <memory>
#include <optional>
#include <vector>

#include "imufusion/fusion.hpp"
#include "imufusion/volume.hpp"
#include "vk/buffer.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"
#include "vk/pipeline.hpp"

namespace imufusion::gpu {

class TsdfVolume {
 public:
  static Result<TsdfVolume> create(std::shared_ptr<Context> context, const VolumeConfig& config,
                                   int workgroup_x = 16, int workgroup_y = 16);

  /// Allocates the blocks around `depth` (metres, on the GPU) and integrates it (and `color`,
  /// RGBA8 per pixel, when given) seen from T_world_camera. Returns the frame's statistics.
  Result<IntegrationStats> integrate(const Buffer& depth, const Buffer* color,
                                     const Intrinsics& intrinsics,
                                     const Eigen::Isometry3d& T_world_camera,
                                     std::vector<KernelTiming>* timings = nullptr);

  /// Raycasts the model from T_world_camera into `vertices`, `normals` (vec4, camera frame),
  /// `shaded` and `colors` (RGBA8), each sized for the intrinsics.
  Status raycast(const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera,
                 float near_depth, float far_depth, const Buffer& vertices, const Buffer& normals,
                 const Buffer& shaded, const Buffer& colors,
                 std::vector<KernelTiming>* timings = nullptr);

  /// Dispatches record_integrate() and record_raycast() add to a sequence.
  static constexpr std::uint32_t kIntegrateDispatches = 5, kRaycastDispatches = 4;
  static constexpr std::uint32_t kGrowDispatches = 5;  // reserve_blocks()

  /// integrate() recorded into `seq` (kIntegrateDispatches) without submitting. One integration
  /// may be in flight: once the submission has completed, finish_integrate() returns its
  /// statistics, or nothing when the frame overflowed a pool that could still grow: then nothing
  /// was fused, the pool has grown, and the caller records the integration again (with what
  /// followed it in the submission, such as the raycast).
  Status record_integrate(CommandSequence& seq, const Buffer& depth, const Buffer* color,
                          const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera);
  Result<std::optional<IntegrationStats>> finish_integrate();
  /// Grows the pool to hold at least `blocks` (a no-op when it does): larger buffers, the blocks
  /// copied on the device. An error, the volume unchanged, beyond VolumeConfig::block_capacity.
  Status reserve_blocks(std::uint32_t blocks);
  /// raycast() recorded into `seq` (kRaycastDispatches) without submitting; it sees the blocks that
  /// an integration recorded before it allocates.
  Status record_raycast(CommandSequence& seq, const Intrinsics& intrinsics,
                        const Eigen::Isometry3d& T_world_camera, float near_depth, float far_depth,
                        const Buffer& vertices, const Buffer& normals, const Buffer& shaded,
                        const Buffer& colors);

  /// March steps of each ray (row-major pixels) of the last raycast: where the time goes.
  Result<std::vector<std::uint32_t>> last_raycast_steps() const;

  /// An allocated block of the hash table: its coordinate, pool index and the frame stamp of the
  /// last integration that touched it (frame_stamp() then).
  struct BlockEntry {
    Eigen::Vector3i coord = Eigen::Vector3i::Zero();
    std::uint32_t pool = 0;
    std::uint32_t stamp = 0;
  };
  /// The allocated blocks, in slot order (downloads the hash table, 12 bytes per slot).
  Result<std::vector<BlockEntry>> block_entries() const;
  /// A snapshot of the listed blocks only: their voxels are downloaded in runs of consecutive pool
  /// indices, one transfer per run.
  Result<HostVolume> snapshot_blocks(std::vector<BlockEntry> blocks) const;
  Result<HostVolume> snapshot() const;
  /// Empties the volume.
  Status reset();

  /// What a saved scan keeps of the volume: the occupied hash slots and the pool's stored blocks,
  /// in the GPU's own words, so that a restored volume is the saved one slot for slot.
  struct Contents {
    std::uint32_t hash_slots = 0;
    std::uint32_t allocated = 0;  // blocks asked for (VOLUME_COUNTER_ALLOCATED; may pass capacity)
    std::uint32_t frame_stamp = 0;
    // The last integration's counters (VOLUME_COUNTERS words), which the next raycast reads.
    std::vector<std::uint32_t> counters;
    std::vector<std::uint32_t> slots, keys, values, stamps;  // per occupied slot, ascending slots
    // Pool blocks [0, stored): kBlockVoxels words each, tsdf (snorm16) | weight << 16 and RGBA8.
    std::vector<std::uint32_t> tsdf_weight, colors;
    std::size_t stored_blocks() const { return tsdf_weight.size() / kBlockVoxels; }
  };
  /// Downloads the hash table and the stored blocks' voxels.
  Result<Contents> contents() const;
  /// Replaces the volume by `contents` (those of a volume with the same hash_slots). Fails, before
  /// changing anything, on contents that do not fit together and when the pool cannot hold their
  /// blocks.
  Status restore(const Contents& contents);

  /// The stamp of the last integration recorded (0 after reset()); blocks it touched carry it.
  std::uint32_t frame_stamp() const { return frame_stamp_; }
  /// Counts reset() calls and stamp wraps: stamps of different epochs are not comparable.
  std::uint64_t epoch() const { return epoch_; }

  const VolumeConfig& config() const { return config_; }
  /// Blocks with pool storage.
  std::uint32_t allocated_blocks() const { return std::min(allocated_counter_, pool_blocks_); }
  /// Blocks the pool holds now, and how many times it grew since creation.
  std::uint32_t pool_blocks() const { return pool_blocks_; }
  std::uint32_t pool_growths() const { return pool_growths_; }
  /// Device memory the volume reserves now (bytes, VolumeConfig::reserved_bytes).
  std::uint64_t reserved_bytes() const { return config_.reserved_bytes(pool_blocks_); }
  const std::shared_ptr<Context>& context() const { return context_; }

 private:
  /// Ensures range_ holds the range image of a width x height raycast.
  Status reserve_range(int width, int height);
  // The hash table's words, one per slot.
  struct HashTable {
    std::vector<std::uint32_t> keys, values, stamps;
  };
  Result<HashTable> download_table() const;
  /// Makes room in the pool for `blocks` blocks; fails naming both counts when it cannot.
  Status reserve_pool(std::uint32_t blocks);
  static Status check_contents(const Contents& c, std::uint32_t hash_slots);
  /// Records the pass that turns the counters into the indirect workgroup counts (args_).
  void record_args(CommandSequence& seq);
  /// The pool size to grow to for `needed` blocks: at least half again the present size, at most
  /// the capacity.
  std::uint32_t grown_pool(std::uint64_t needed) const;

  std::shared_ptr<Context> context_;
  VolumeConfig config_;
  ComputePipeline allocate_, args_pipeline_, integrate_, range_pipeline_, raycast_, grow_;
  Buffer keys_, values_, stamps_, visible_, counters_, block_slots_, tsdf_weight_, voxel_colors_,
      no_color_, range_, steps_, args_;
  // Host-visible: the counters a frame starts from, and their copy after each pass (read by the
  // host without a transfer of its own).
  Buffer counters_start_, counters_readback_;
  std::size_t raycast_pixels_ = 0;
  CommandSequence seq_;
  std::uint32_t frame_stamp_ = 0;
  std::uint64_t epoch_ = 0;
  // VOLUME_COUNTER_ALLOCATED as last read: blocks asked for, which may pass the pool.
  std::uint32_t allocated_counter_ = 0;
  std::uint32_t pool_blocks_ = 0, pool_growths_ = 0;
  // The most blocks one frame has added to a volume that was not empty: the headroom kept when
  // growing ahead of need.
  std::uint32_t largest_frame_blocks_ = 0;
};

}  // namespace imufusion::gpu
