// TsdfVolume's contents for a saved scan (Reconstructor::save / load): download and restore.

#include <string>

#include "gpu/volume.hpp"
#include "imufusion_layouts.h"

namespace imufusion::gpu {

Result<TsdfVolume::Contents> TsdfVolume::contents() const {
  Contents c;
  c.hash_slots = config_.hash_slots;
  c.allocated = allocated_counter_;
  c.frame_stamp = frame_stamp_;
  auto counters = counters_.download_as<std::uint32_t>(VOLUME_COUNTERS);
  if (!counters) return counters.error();
  c.counters = std::move(*counters);
  auto table = download_table();
  if (!table) return table.error();
  for (std::uint32_t slot = 0; slot < config_.hash_slots; ++slot) {
    if (table->keys[slot] == VOLUME_EMPTY_KEY) continue;
    c.slots.push_back(slot);
    c.keys.push_back(table->keys[slot]);
    c.values.push_back(table->values[slot]);
    c.stamps.push_back(table->stamps[slot]);
  }
  const std::size_t words = std::size_t{allocated_blocks()} * kBlockVoxels;
  c.tsdf_weight.resize(words);
  c.colors.resize(words);
  IMUFUSION_RETURN_IF_ERROR(tsdf_weight_.download(c.tsdf_weight.data(), words * 4));
  IMUFUSION_RETURN_IF_ERROR(voxel_colors_.download(c.colors.data(), words * 4));
  return c;
}

// The one place a restore asks for pool room: the pool grows to hold the saved blocks, up to
// block_capacity.
Status TsdfVolume::reserve_pool(std::uint32_t blocks) {
  if (blocks <= config_.block_capacity) return reserve_blocks(blocks);
  return make_error(ErrorCode::kInvalidArgument,
                    "the saved volume holds " + std::to_string(blocks) +
                        " blocks, this volume's pool only " +
                        std::to_string(config_.block_capacity) + " (volume.block_capacity)");
}

Status TsdfVolume::check_contents(const Contents& c, std::uint32_t hash_slots) {
  auto bad = [](const std::string& what) {
    return make_error(ErrorCode::kParseError, "volume contents: " + what);
  };
  if (c.hash_slots != hash_slots)
    return bad(std::to_string(c.hash_slots) + " hash slots, the volume has " +
               std::to_string(hash_slots));
  if (c.counters.size() != VOLUME_COUNTERS)
    return bad(std::to_string(c.counters.size()) + " counters, the volume has " +
               std::to_string(VOLUME_COUNTERS));
  const std::size_t n = c.slots.size();
  if (c.keys.size() != n || c.values.size() != n || c.stamps.size() != n)
    return bad("slot, key, value and stamp lists of different lengths");
  if (c.colors.size() != c.tsdf_weight.size() || c.tsdf_weight.size() % kBlockVoxels != 0)
    return bad("voxel arrays not a whole number of blocks");
  const std::size_t stored = c.stored_blocks();
  if (stored > c.allocated) return bad("more blocks stored than allocated");
  for (std::size_t i = 0; i < n; ++i) {
    if (c.slots[i] >= hash_slots || (i > 0 && c.slots[i] <= c.slots[i - 1]))
      return bad("slot " + std::to_string(c.slots[i]) + " out of order or range");
    if (c.keys[i] == VOLUME_EMPTY_KEY) return bad("an occupied slot holds the empty key");
    if (c.values[i] != VOLUME_NO_BLOCK && c.values[i] >= stored)
      return bad("slot " + std::to_string(c.slots[i]) + " points at block " +
                 std::to_string(c.values[i]) + " of " + std::to_string(stored));
  }
  return {};
}

Status TsdfVolume::restore(const Contents& c) {
  IMUFUSION_RETURN_IF_ERROR(check_contents(c, config_.hash_slots));
  IMUFUSION_RETURN_IF_ERROR(reserve_pool(static_cast<std::uint32_t>(c.stored_blocks())));
  IMUFUSION_RETURN_IF_ERROR(reset());
  std::vector<std::uint32_t> keys(config_.hash_slots, VOLUME_EMPTY_KEY),
      values(config_.hash_slots, 0), stamps(config_.hash_slots, 0),
      block_slots(config_.block_capacity, 0);
  for (std::size_t i = 0; i < c.slots.size(); ++i) {
    keys[c.slots[i]] = c.keys[i];
    values[c.slots[i]] = c.values[i];
    stamps[c.slots[i]] = c.stamps[i];
    if (c.values[i] != VOLUME_NO_BLOCK) block_slots[c.values[i]] = c.slots[i];
  }
  IMUFUSION_RETURN_IF_ERROR(keys_.upload(std::span<const std::uint32_t>(keys)));
  IMUFUSION_RETURN_IF_ERROR(values_.upload(std::span<const std::uint32_t>(values)));
  IMUFUSION_RETURN_IF_ERROR(stamps_.upload(std::span<const std::uint32_t>(stamps)));
  IMUFUSION_RETURN_IF_ERROR(block_slots_.upload(std::span<const std::uint32_t>(block_slots)));
  IMUFUSION_RETURN_IF_ERROR(counters_.upload(std::span<const std::uint32_t>(c.counters)));
  if (!c.tsdf_weight.empty()) {
    IMUFUSION_RETURN_IF_ERROR(tsdf_weight_.upload(std::span<const std::uint32_t>(c.tsdf_weight)));
    IMUFUSION_RETURN_IF_ERROR(voxel_colors_.upload(std::span<const std::uint32_t>(c.colors)));
  }
  allocated_counter_ = c.allocated;
  frame_stamp_ = c.frame_stamp;
  return {};
}

}  // namespace imufusion::gpu
