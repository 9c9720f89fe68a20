#pragma once
// The sparse TSDF volume as the host sees it: 8^3-voxel blocks allocated only near observed
// surfaces (VoxelHashing, Niessner et al. 2013). The GPU keeps the live volume; a HostVolume is
// a snapshot of its allocated blocks, the input of meshing and of the CPU reference kernels.
//
// Geometry: voxel (i, j, k) of the block with coordinate b samples the TSDF at the world point
// (8 b + (i, j, k)) * voxel_size (metres, world frame): the lattice is corner-aligned, so block b
// covers [8 b, 8 b + 8) * voxel_size on each axis, and marching cubes between the last voxel of a
// block and the first of its neighbour uses the neighbour block.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace imufusion {

constexpr int kBlockSide = 8;                                       // voxels per block edge
constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;  // 512

/// Index of voxel (i, j, k) inside its block.
constexpr int voxel_index(int i, int j, int k) { return i + kBlockSide * (j + kBlockSide * k); }

struct VolumeConfig {
  float voxel_size = 0.01f;                 // metres
  float truncation_voxels = 4.0f;           // truncation band, in voxels (default ~4)
  int max_weight = 128;                     // running-average weight cap (observations)
  std::uint32_t initial_blocks = 4096;      // blocks the pool holds at first (16 MiB); it grows
                                            // on the device as the scene needs, to block_capacity
  std::uint32_t block_capacity = 1u << 16;  // most blocks the pool may hold: 4 KiB each (8 bytes
                                            // per voxel); past them new surface is not fused
  std::uint32_t hash_slots = 1u << 18;      // hash-table slots (a power of two, >= capacity)

  float truncation() const { return truncation_voxels * voxel_size; }  // metres
  /// Device memory (bytes) of the volume with a pool of `pool_blocks` blocks (8 bytes per voxel),
  /// its hash-slot index for each of block_capacity blocks, and per hash slot a key, pool index,
  /// frame stamp and visible-list entry.
  std::uint64_t reserved_bytes(std::uint32_t pool_blocks) const {
    return std::uint64_t{pool_blocks} * kBlockVoxels * 8 + std::uint64_t{block_capacity} * 4 +
           std::uint64_t{hash_slots} * 16;
  }
};

/// One voxel, unpacked: tsdf in truncation units, [-1, 1] (positive in front of the surface);
/// weight 0 = never observed; colour 8-bit RGB.
struct Voxel {
  float tsdf = 1.0f;
  float weight = 0.0f;
  std::array<std::uint8_t, 3> color = {0, 0, 0};
};

struct VolumeBlock {
  Eigen::Vector3i coord = Eigen::Vector3i::Zero();
  std::array<Voxel, kBlockVoxels> voxels{};
};

/// A snapshot of the allocated blocks (any order, each coordinate once).
struct HostVolume {
  float voxel_size = 0.01f;
  float truncation = 0.04f;  // metres
  std::vector<VolumeBlock> blocks;
};

}  // namespace imufusion
