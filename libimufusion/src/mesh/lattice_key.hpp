#pragma once
// 64-bit keys for blocks and lattice edges of the sparse volume, for hash maps.

#include <Eigen/Core>
#include <cstdint>
#include <cstdlib>

#include "imufusion/volume.hpp"

namespace imufusion::mesh {

/// Supported block coordinates: |c| < 2^15 on each axis (2.6 km at 1 cm voxels), so voxel
/// coordinates, |v| < 2^18 + kBlockSide + 1, fit 20-bit two's complement.
constexpr int kMaxBlockCoord = 1 << 15;

inline bool block_in_range(const Eigen::Vector3i& c) {
  return std::abs(c.x()) < kMaxBlockCoord && std::abs(c.y()) < kMaxBlockCoord &&
         std::abs(c.z()) < kMaxBlockCoord;
}

/// Three signed 20-bit coordinates packed into bits 0-59.
inline std::uint64_t pack20(const Eigen::Vector3i& c) {
  constexpr std::uint64_t mask = (std::uint64_t{1} << 20) - 1;
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x())) & mask) |
         ((static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y())) & mask) << 20) |
         ((static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z())) & mask) << 40);
}

inline std::uint64_t block_key(const Eigen::Vector3i& block) { return pack20(block); }

/// The lattice edge from voxel `lower` (global voxel coordinates) one step along `axis` (0-2).
inline std::uint64_t edge_key(const Eigen::Vector3i& lower, int axis) {
  return pack20(lower) | (static_cast<std::uint64_t>(axis) << 60);
}

}  // namespace imufusion::mesh
