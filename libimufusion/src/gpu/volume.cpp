#include "gpu/volume.hpp"

#include <algorithm>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "imufusion_layouts.h"

namespace imufusion::gpu {
namespace {

template <typename Params>
void set_pose(Params& p, const Eigen::Isometry3d& T) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  p.r00 = R(0, 0), p.r01 = R(0, 1), p.r02 = R(0, 2), p.tx = t.x();
  p.r10 = R(1, 0), p.r11 = R(1, 1), p.r12 = R(1, 2), p.ty = t.y();
  p.r20 = R(2, 0), p.r21 = R(2, 1), p.r22 = R(2, 2), p.tz = t.z();
}

template <typename Params>
void set_intrinsics(Params& p, const Intrinsics& k) {
  p.width = static_cast<std::uint32_t>(k.width);
  p.height = static_cast<std::uint32_t>(k.height);
  p.fx = static_cast<float>(k.fx);
  p.fy = static_cast<float>(k.fy);
  p.cx = static_cast<float>(k.cx);
  p.cy = static_cast<float>(k.cy);
}

Status check_config(const VolumeConfig& c, const VkPhysicalDeviceLimits& limits) {
  auto bad = [](const std::string& what) { return make_error(ErrorCode::kInvalidArgument, what); };
  if (!(c.voxel_size > 0.0005f && c.voxel_size < 1.0f))
    return bad("voxel size must be in (0.5 mm, 1 m), got " + std::to_string(c.voxel_size));
  if (!(c.truncation_voxels >= 1.0f)) return bad("truncation must be at least one voxel");
  if (c.max_weight < 1 || c.max_weight > 65535) return bad("max_weight must be 1..65535");
  if (c.block_capacity == 0) return bad("block capacity must be positive");
  if (c.initial_blocks == 0) return bad("initial_blocks must be positive");
  if (c.hash_slots < 2 || (c.hash_slots & (c.hash_slots - 1)) != 0 ||
      c.hash_slots < c.block_capacity)
    return bad("hash_slots must be a power of two >= block_capacity, got " +
               std::to_string(c.hash_slots));
  // Each voxel array (4 bytes per voxel) is one storage-buffer binding.
  const std::uint64_t pool_bytes = std::uint64_t{c.block_capacity} * kBlockVoxels * 4;
  if (pool_bytes > limits.maxStorageBufferRange ||
      std::uint64_t{c.hash_slots} * 4 > limits.maxStorageBufferRange) {
    return bad("block capacity " + std::to_string(c.block_capacity) + " needs voxel arrays of " +
               std::to_string(pool_bytes >> 20) +
               " MiB, beyond this device's storage-buffer range of " +
               std::to_string(limits.maxStorageBufferRange >> 20) + " MiB (at most " +
               std::to_string(limits.maxStorageBufferRange / (kBlockVoxels * 4)) + " blocks)");
  }
  return {};
}

}  // namespace

Result<TsdfVolume> TsdfVolume::create(std::shared_ptr<Context> context, const VolumeConfig& config,
                                      int workgroup_x, int workgroup_y) {
  IMUFUSION_RETURN_IF_ERROR(check_config(config, context->limits()));
  TsdfVolume v;
  v.context_ = context;
  v.config_ = config;
  const auto wx = static_cast<std::uint32_t>(workgroup_x),
             wy = static_cast<std::uint32_t>(workgroup_y);
  auto make = [&](PipelineDesc desc, ComputePipeline& out) -> Status {
    auto pipeline = ComputePipeline::create(context, desc);
    if (!pipeline) return pipeline.error();
    out = std::move(*pipeline);
    return {};
  };
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_allocate", 7, sizeof(layout::VolumeAllocateParams), wx, wy}, v.allocate_));
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_dispatch_args", 2, sizeof(layout::VolumeArgsParams), 1, 1}, v.args_pipeline_));
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_integrate", 8, sizeof(layout::VolumeIntegrateParams), 8, 8}, v.integrate_));
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_raycast_range", 5, sizeof(layout::VolumeRangeParams), VOLUME_RANGE_GROUP, 1},
           v.range_pipeline_));
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_raycast", 10, sizeof(layout::VolumeRaycastParams), wx, wy}, v.raycast_));
  IMUFUSION_RETURN_IF_ERROR(
      make({"volume_pool_grow", 2, sizeof(layout::VolumePoolGrowParams), 64, 1}, v.grow_));
  auto alloc = [&](std::size_t bytes, Buffer& out, bool host_visible = false) -> Status {
    auto buffer = Buffer::create(context, bytes, host_visible);
    if (!buffer) return buffer.error();
    out = std::move(*buffer);
    return {};
  };
  const std::size_t slots = config.hash_slots;
  IMUFUSION_RETURN_IF_ERROR(alloc(slots * 4, v.keys_));
  IMUFUSION_RETURN_IF_ERROR(alloc(slots * 4, v.values_));
  IMUFUSION_RETURN_IF_ERROR(alloc(slots * 4, v.stamps_));
  // One visible-list entry per slot: a frame lists each slot at most once (see volume_allocate).
  IMUFUSION_RETURN_IF_ERROR(alloc(slots * 4, v.visible_));
  IMUFUSION_RETURN_IF_ERROR(alloc(VOLUME_COUNTERS * 4, v.counters_));
  IMUFUSION_RETURN_IF_ERROR(alloc(VOLUME_COUNTERS * 4, v.counters_start_, true));
  IMUFUSION_RETURN_IF_ERROR(alloc(VOLUME_COUNTERS * 4, v.counters_readback_, true));
  IMUFUSION_RETURN_IF_ERROR(alloc(std::size_t{config.block_capacity} * 4, v.block_slots_));
  v.pool_blocks_ = std::min(config.initial_blocks, config.block_capacity);
  IMUFUSION_RETURN_IF_ERROR(alloc(std::size_t{v.pool_blocks_} * kBlockVoxels * 4, v.tsdf_weight_));
  IMUFUSION_RETURN_IF_ERROR(alloc(std::size_t{v.pool_blocks_} * kBlockVoxels * 4, v.voxel_colors_));
  IMUFUSION_RETURN_IF_ERROR(alloc(4, v.no_color_));
  IMUFUSION_RETURN_IF_ERROR(alloc(VOLUME_ARGS_WORDS * 4, v.args_));
  auto seq = CommandSequence::create(
      context, std::max({kIntegrateDispatches, kRaycastDispatches, kGrowDispatches}));
  if (!seq) return seq.error();
  v.seq_ = std::move(*seq);
  IMUFUSION_RETURN_IF_ERROR(v.reset());
  return v;
}

Status TsdfVolume::reset() {
  const std::vector<std::uint32_t> empty(config_.hash_slots, VOLUME_EMPTY_KEY);
  IMUFUSION_RETURN_IF_ERROR(keys_.upload(empty.data(), empty.size() * 4));
  IMUFUSION_RETURN_IF_ERROR(values_.clear());
  IMUFUSION_RETURN_IF_ERROR(stamps_.clear());
  IMUFUSION_RETURN_IF_ERROR(counters_.clear());
  IMUFUSION_RETURN_IF_ERROR(tsdf_weight_.clear());
  IMUFUSION_RETURN_IF_ERROR(voxel_colors_.clear());
  frame_stamp_ = 0;
  ++epoch_;
  allocated_counter_ = 0;
  largest_frame_blocks_ = 0;
  return {};
}

Result<IntegrationStats> TsdfVolume::integrate(const Buffer& depth, const Buffer* color,
                                               const Intrinsics& k,
                                               const Eigen::Isometry3d& T_world_camera,
                                               std::vector<KernelTiming>* timings) {
  for (;;) {
    IMUFUSION_RETURN_IF_ERROR(seq_.begin());
    const Status recorded = record_integrate(seq_, depth, color, k, T_world_camera);
    auto t = seq_.submit_and_wait();  // ends the recording also after a failed record
    IMUFUSION_RETURN_IF_ERROR(recorded);
    if (!t) return t.error();
    if (timings != nullptr) timings->insert(timings->end(), t->begin(), t->end());
    auto stats = finish_integrate();
    if (!stats) return stats.error();
    if (*stats) return **stats;
  }
}

void TsdfVolume::record_args(CommandSequence& seq) {
  layout::VolumeArgsParams p{};
  p.pool_blocks = pool_blocks_;
  seq.dispatch(args_pipeline_, {&counters_, &args_}, p, 1, 1, "volume_dispatch_args");
}

Status TsdfVolume::record_integrate(CommandSequence& seq, const Buffer& depth, const Buffer* color,
                                    const Intrinsics& k, const Eigen::Isometry3d& T_world_camera) {
  if (!T_world_camera.matrix().allFinite())
    return make_error(ErrorCode::kInvalidArgument, "integration pose is not finite");
  // Only the allocation count carries over from frame to frame; the counters are set in the same
  // submission as the allocation pass.
  std::uint32_t counters[VOLUME_COUNTERS] = {};
  counters[VOLUME_COUNTER_ALLOCATED] = allocated_counter_;
  IMUFUSION_RETURN_IF_ERROR(counters_start_.upload(counters, sizeof(counters)));
  ++frame_stamp_;
  if (frame_stamp_ == 0) {  // wrapped after 2^32 frames: old stamps could collide
    IMUFUSION_RETURN_IF_ERROR(stamps_.clear());
    frame_stamp_ = 1;
    ++epoch_;
  }

  layout::VolumeAllocateParams ap{};
  set_intrinsics(ap, k);
  set_pose(ap, T_world_camera);
  ap.voxel_size = config_.voxel_size;
  ap.truncation = config_.truncation();
  ap.hash_mask = config_.hash_slots - 1;
  ap.pool_blocks = pool_blocks_;
  ap.frame_stamp = frame_stamp_;
  ap.max_blocks = config_.block_capacity;
  seq.copy(counters_start_, counters_, sizeof(counters), "volume_counters");
  seq.dispatch(allocate_,
               {&depth, &keys_, &values_, &stamps_, &visible_, &counters_, &block_slots_}, ap,
               ap.width, ap.height, "volume_allocate");
  record_args(seq);

  layout::VolumeIntegrateParams ip{};
  set_intrinsics(ip, k);
  set_pose(ip, T_world_camera.inverse());
  ip.voxel_size = config_.voxel_size;
  ip.truncation = config_.truncation();
  ip.max_weight = static_cast<std::uint32_t>(config_.max_weight);
  ip.has_color = color != nullptr ? 1u : 0u;
  ip.defer_above = pool_blocks_ < config_.block_capacity ? pool_blocks_ : VOLUME_NO_BLOCK;
  // One 8x8 workgroup per listed slot, counted on the GPU (volume_dispatch_args).
  seq.dispatch_indirect(integrate_,
                        {&depth, color != nullptr ? color : &no_color_, &keys_, &values_, &visible_,
                         &tsdf_weight_, &voxel_colors_, &counters_},
                        ip, args_, VOLUME_ARGS_INTEGRATE * 4, "volume_integrate");
  seq.copy(counters_, counters_readback_, sizeof(counters), "volume_counters");
  return {};
}

Result<std::optional<IntegrationStats>> TsdfVolume::finish_integrate() {
  std::uint32_t counters[VOLUME_COUNTERS] = {};
  // Host-visible: the download is a copy from mapped memory and cannot fail once mapped.
  (void)counters_readback_.download(counters, sizeof(counters));
  const std::uint32_t allocated = counters[VOLUME_COUNTER_ALLOCATED];
  // The first frame into an empty volume finds all its surface new; the frames after it, only
  // what the camera uncovers: they set the headroom.
  if (allocated_counter_ > 0)
    largest_frame_blocks_ = std::max(largest_frame_blocks_, allocated - allocated_counter_);
  allocated_counter_ = allocated;
  if (allocated > pool_blocks_ && pool_blocks_ < config_.block_capacity) {
    // The integration pass deferred: the frame's blocks have no storage yet, nothing was fused.
    IMUFUSION_RETURN_IF_ERROR(reserve_blocks(grown_pool(allocated)));
    return std::optional<IntegrationStats>{};
  }
  const std::uint64_t ahead = std::uint64_t{allocated} + largest_frame_blocks_;
  if (ahead > pool_blocks_ && pool_blocks_ < config_.block_capacity)
    IMUFUSION_RETURN_IF_ERROR(reserve_blocks(grown_pool(ahead)));
  IntegrationStats stats;
  const std::uint32_t listed = counters[VOLUME_COUNTER_VISIBLE];  // touched slots, <= hash_slots
  stats.allocated_blocks = allocated_blocks();
  stats.table_full = counters[VOLUME_COUNTER_TABLE_FULL];
  stats.out_of_range = counters[VOLUME_COUNTER_OUT_OF_RANGE];
  // Every touched block is either fused or counted as refused by the full pool.
  stats.pool_full = counters[VOLUME_COUNTER_POOL_FULL];
  stats.visible_blocks = listed - stats.pool_full;
  return std::optional<IntegrationStats>{stats};
}

std::uint32_t TsdfVolume::grown_pool(std::uint64_t needed) const {
  const std::uint64_t geometric = std::uint64_t{pool_blocks_} + pool_blocks_ / 2;
  return static_cast<std::uint32_t>(
      std::min<std::uint64_t>(std::max(needed, geometric), config_.block_capacity));
}

Status TsdfVolume::reserve_blocks(std::uint32_t blocks) {
  if (blocks <= pool_blocks_) return {};
  if (blocks > config_.block_capacity)
    return make_error(ErrorCode::kInvalidArgument, "cannot reserve " + std::to_string(blocks) +
                                                       " blocks: the volume's block_capacity is " +
                                                       std::to_string(config_.block_capacity));
  const VkDeviceSize bytes = VkDeviceSize{blocks} * kBlockVoxels * 4;
  const auto growing = [&](Error e) {
    e.message = "growing the TSDF block pool to " + std::to_string(blocks) + " blocks (" +
                std::to_string((2 * bytes) >> 20) + " MiB): " + e.message;
    return e;
  };
  auto tsdf_weight = Buffer::create(context_, bytes);
  if (!tsdf_weight) return growing(tsdf_weight.error());
  auto colors = Buffer::create(context_, bytes);
  if (!colors) return growing(colors.error());
  IMUFUSION_RETURN_IF_ERROR(seq_.begin());
  for (auto [from, to] : {std::pair{&tsdf_weight_, &*tsdf_weight}, {&voxel_colors_, &*colors}}) {
    seq_.fill(*to, 0, "volume_pool_clear");
    seq_.copy(*from, *to, from->size(), "volume_pool_copy");
  }
  // Blocks a deferred frame was refused get the storage now held for them.
  const std::uint32_t refused_end = std::min(allocated_counter_, blocks);
  if (refused_end > pool_blocks_) {
    const layout::VolumePoolGrowParams p{pool_blocks_, refused_end - pool_blocks_};
    seq_.dispatch(grow_, {&values_, &block_slots_}, p, p.count, 1, "volume_pool_grow");
  }
  auto t = seq_.submit_and_wait();
  if (!t) return growing(t.error());
  tsdf_weight_ = std::move(*tsdf_weight);
  voxel_colors_ = std::move(*colors);
  pool_blocks_ = blocks;
  ++pool_growths_;
  return {};
}

Status TsdfVolume::raycast(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                           float near_depth, float far_depth, const Buffer& vertices,
                           const Buffer& normals, const Buffer& shaded, const Buffer& colors,
                           std::vector<KernelTiming>* timings) {
  IMUFUSION_RETURN_IF_ERROR(seq_.begin());
  const Status recorded = record_raycast(seq_, k, T_world_camera, near_depth, far_depth, vertices,
                                         normals, shaded, colors);
  auto t = seq_.submit_and_wait();
  IMUFUSION_RETURN_IF_ERROR(recorded);
  if (!t) return t.error();
  if (timings != nullptr) timings->insert(timings->end(), t->begin(), t->end());
  return {};
}

Status TsdfVolume::record_raycast(CommandSequence& seq, const Intrinsics& k,
                                  const Eigen::Isometry3d& T_world_camera, float near_depth,
                                  float far_depth, const Buffer& vertices, const Buffer& normals,
                                  const Buffer& shaded, const Buffer& colors) {
  if (!T_world_camera.matrix().allFinite())
    return make_error(ErrorCode::kInvalidArgument, "raycast pose is not finite");
  layout::VolumeRaycastParams rp{};
  set_intrinsics(rp, k);
  set_pose(rp, T_world_camera);
  rp.voxel_size = config_.voxel_size;
  rp.truncation = config_.truncation();
  rp.near_depth = near_depth;
  rp.far_depth = far_depth;
  rp.hash_mask = config_.hash_slots - 1;
  rp.range_width = (rp.width + VOLUME_RANGE_TILE - 1) / VOLUME_RANGE_TILE;
  IMUFUSION_RETURN_IF_ERROR(reserve_range(k.width, k.height));

  layout::VolumeRangeParams qp{};
  set_intrinsics(qp, k);
  set_pose(qp, T_world_camera.inverse());
  qp.voxel_size = config_.voxel_size;
  qp.near_depth = near_depth;
  qp.range_width = rp.range_width;
  qp.pool_blocks = pool_blocks_;
  record_args(seq);
  seq.fill(range_, 0, "volume_raycast_range_clear");
  seq.dispatch_indirect(range_pipeline_, {&keys_, &values_, &block_slots_, &range_, &counters_}, qp,
                        args_, VOLUME_ARGS_RANGE * 4, "volume_raycast_range");
  seq.dispatch(raycast_,
               {&keys_, &values_, &tsdf_weight_, &voxel_colors_, &vertices, &normals, &shaded,
                &colors, &range_, &steps_},
               rp, rp.width, rp.height, "volume_raycast");
  return {};
}

Status TsdfVolume::reserve_range(int width, int height) {
  const std::size_t cells = std::size_t((width + VOLUME_RANGE_TILE - 1) / VOLUME_RANGE_TILE) *
                            std::size_t((height + VOLUME_RANGE_TILE - 1) / VOLUME_RANGE_TILE);
  const std::size_t pixels = std::size_t(width) * std::size_t(height);
  for (auto [buffer, bytes] : {std::pair{&range_, cells * 8}, {&steps_, pixels * 4}}) {
    if (buffer->size() >= bytes) continue;
    auto created = Buffer::create(context_, bytes);
    if (!created) return created.error();
    *buffer = std::move(*created);
  }
  raycast_pixels_ = pixels;
  return {};
}

Result<std::vector<std::uint32_t>> TsdfVolume::last_raycast_steps() const {
  if (raycast_pixels_ == 0) return std::vector<std::uint32_t>{};
  return steps_.download_as<std::uint32_t>(raycast_pixels_);
}

Result<TsdfVolume::HashTable> TsdfVolume::download_table() const {
  HashTable table;
  for (auto [buffer, words] : {std::pair{&keys_, &table.keys}, std::pair{&values_, &table.values},
                               std::pair{&stamps_, &table.stamps}}) {
    auto downloaded = buffer->download_as<std::uint32_t>(config_.hash_slots);
    if (!downloaded) return downloaded.error();
    *words = std::move(*downloaded);
  }
  return table;
}

Result<std::vector<TsdfVolume::BlockEntry>> TsdfVolume::block_entries() const {
  auto table = download_table();
  if (!table) return table.error();
  const auto* keys = &table->keys;
  const auto* values = &table->values;
  const auto* stamps = &table->stamps;
  std::vector<BlockEntry> entries;
  for (std::size_t slot = 0; slot < keys->size(); ++slot) {
    const std::uint32_t key = (*keys)[slot];
    const std::uint32_t block = (*values)[slot];
    if (key == VOLUME_EMPTY_KEY || block == VOLUME_NO_BLOCK || block >= allocated_blocks())
      continue;
    BlockEntry entry;
    entry.coord = Eigen::Vector3i(static_cast<int>(key & 0x7FFu) - 1024,
                                  static_cast<int>((key >> 11) & 0x7FFu) - 1024,
                                  static_cast<int>(key >> 22) - 512);
    entry.pool = block;
    entry.stamp = (*stamps)[slot];
    entries.push_back(entry);
  }
  return entries;
}

namespace {

// A block's voxels from its packed words: tsdf (snorm16) and weight, RGB colour.
void unpack_block(const std::uint32_t* tsdf_weight, const std::uint32_t* colors, VolumeBlock& b) {
  for (std::size_t v = 0; v < kBlockVoxels; ++v) {
    const std::uint32_t word0 = tsdf_weight[v], word1 = colors[v];
    Voxel& voxel = b.voxels[v];
    voxel.tsdf = static_cast<float>(static_cast<std::int16_t>(word0 & 0xFFFFu)) / 32767.0f;
    voxel.weight = static_cast<float>(word0 >> 16);
    voxel.color = {static_cast<std::uint8_t>(word1 & 0xFF),
                   static_cast<std::uint8_t>((word1 >> 8) & 0xFF),
                   static_cast<std::uint8_t>((word1 >> 16) & 0xFF)};
  }
}

}  // namespace

Result<HostVolume> TsdfVolume::snapshot_blocks(std::vector<BlockEntry> blocks) const {
  std::sort(blocks.begin(), blocks.end(),
            [](const BlockEntry& a, const BlockEntry& b) { return a.pool < b.pool; });
  HostVolume host;
  host.voxel_size = config_.voxel_size;
  host.truncation = config_.truncation();
  host.blocks.resize(blocks.size());
  std::vector<std::uint32_t> tsdf_weight, colors;
  for (std::size_t first = 0, last = 0; first < blocks.size(); first = last) {
    last = first + 1;
    while (last < blocks.size() && blocks[last].pool == blocks[last - 1].pool + 1) ++last;
    const std::size_t words = (last - first) * kBlockVoxels;
    const VkDeviceSize offset = VkDeviceSize{blocks[first].pool} * kBlockVoxels * 4;
    tsdf_weight.resize(words);
    colors.resize(words);
    IMUFUSION_RETURN_IF_ERROR(tsdf_weight_.download(tsdf_weight.data(), words * 4, offset));
    IMUFUSION_RETURN_IF_ERROR(voxel_colors_.download(colors.data(), words * 4, offset));
    for (std::size_t b = first; b < last; ++b) {
      const std::size_t at = (b - first) * kBlockVoxels;
      host.blocks[b].coord = blocks[b].coord;
      unpack_block(tsdf_weight.data() + at, colors.data() + at, host.blocks[b]);
    }
  }
  return host;
}

Result<HostVolume> TsdfVolume::snapshot() const {
  auto entries = block_entries();
  if (!entries) return entries.error();
  return snapshot_blocks(std::move(*entries));
}

}  // namespace imufusion::gpu
