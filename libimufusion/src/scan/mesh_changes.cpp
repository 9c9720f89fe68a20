#include "scan/mesh_changes.hpp"

#include <algorithm>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mesh/lattice_key.hpp"
#include "scan/reconstructor_impl.hpp"

namespace imufusion {
namespace {

// The block coordinate packed by mesh::block_key.
Eigen::Vector3i unpack_block_key(std::uint64_t key) {
  auto field = [&](int shift) {
    const auto bits = static_cast<std::int32_t>((key >> shift) & 0xFFFFFu);
    return (bits & 0x80000) != 0 ? bits - 0x100000 : bits;  // 20-bit two's complement
  };
  return {field(0), field(20), field(40)};
}

// Each block and its 26 neighbours, once each, by key.
std::unordered_set<std::uint64_t> with_neighbours(const std::vector<Eigen::Vector3i>& blocks) {
  std::unordered_set<std::uint64_t> keys;
  keys.reserve(blocks.size() * 8);
  for (const Eigen::Vector3i& c : blocks) {
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx)
          keys.insert(mesh::block_key(c + Eigen::Vector3i(dx, dy, dz)));
      }
    }
  }
  return keys;
}

bool zyx_less(const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
  return std::tie(a.z(), a.y(), a.x()) < std::tie(b.z(), b.y(), b.x());
}

bool same_options(const MeshOptions& a, const MeshOptions& b) {
  return a.min_weight == b.min_weight && a.colors == b.colors;
}

}  // namespace

std::vector<Eigen::Vector3i> MeshChangeTracker::dirty_blocks(
    const std::vector<gpu::TsdfVolume::BlockEntry>& entries, bool full) const {
  std::vector<Eigen::Vector3i> touched;
  for (const auto& entry : entries) {
    if (full || entry.stamp > since_stamp_) touched.push_back(entry.coord);
  }
  std::unordered_set<std::uint64_t> keys = with_neighbours(touched);
  if (full) keys.insert(reported_.begin(), reported_.end());
  std::vector<Eigen::Vector3i> dirty;
  dirty.reserve(keys.size());
  for (std::uint64_t key : keys) {
    const Eigen::Vector3i c = unpack_block_key(key);
    if (mesh::block_in_range(c)) dirty.push_back(c);
  }
  std::sort(dirty.begin(), dirty.end(), zyx_less);
  return dirty;
}

Result<MeshUpdate> MeshChangeTracker::extract(const gpu::TsdfVolume& volume,
                                              const MeshOptions& options) {
  const bool full =
      !started_ || epoch_ != volume.epoch() || !options_ || !same_options(*options_, options);
  started_ = false;  // until this call succeeds
  auto entries = volume.block_entries();
  if (!entries) return entries.error();
  const std::vector<Eigen::Vector3i> dirty = dirty_blocks(*entries, full);
  // The voxels the dirty blocks' cells read: theirs and their neighbours'.
  const std::unordered_set<std::uint64_t> needed = with_neighbours(dirty);
  std::vector<gpu::TsdfVolume::BlockEntry> download;
  for (const auto& entry : *entries) {
    if (needed.contains(mesh::block_key(entry.coord))) download.push_back(entry);
  }
  auto host = volume.snapshot_blocks(std::move(download));
  if (!host) return host.error();
  auto pieces = extract_block_meshes(*host, dirty, options);
  if (!pieces) return pieces.error();

  MeshUpdate update;
  for (BlockMesh& piece : *pieces) {
    const std::uint64_t key = mesh::block_key(piece.block);
    if (!piece.mesh.triangles.empty()) {
      reported_.insert(key);
      update.changed.push_back(std::move(piece));
    } else if (reported_.erase(key) > 0) {
      update.removed.push_back(piece.block);
    }
  }
  started_ = true;
  epoch_ = volume.epoch();
  since_stamp_ = volume.frame_stamp();
  options_ = options;
  return update;
}

Result<MeshUpdate> Reconstructor::extract_mesh_changes(const MeshOptions& options) {
  return impl_->mesh_changes.extract(impl_->volume, options);
}

}  // namespace imufusion
