#pragma once
// Volumes written straight from analytic signed distance functions, for the mesh tests.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "imufusion/mesh.hpp"
#include "imufusion/volume.hpp"

namespace imufusion::test {

using Sdf = std::function<double(const Eigen::Vector3d&)>;
using ColorFn = std::function<std::array<std::uint8_t, 3>(const Eigen::Vector3d&)>;

/// Every block of the box [lo, hi] (block coordinates, inclusive) whose centre is within
/// truncation + half a block diagonal of the surface, filled with tsdf = clamp(sdf / truncation)
/// and weight 1 (so every cell the surface crosses has all its blocks).
inline HostVolume make_sdf_volume(const Sdf& sdf, const Eigen::Vector3i& lo,
                                  const Eigen::Vector3i& hi, float voxel_size = 0.01f,
                                  float truncation_voxels = 4.0f, const ColorFn& color = {}) {
  HostVolume volume;
  volume.voxel_size = voxel_size;
  volume.truncation = truncation_voxels * voxel_size;
  const double block_size = kBlockSide * static_cast<double>(voxel_size);
  const double reach = volume.truncation + 0.5 * std::sqrt(3.0) * block_size;
  for (int z = lo.z(); z <= hi.z(); ++z) {
    for (int y = lo.y(); y <= hi.y(); ++y) {
      for (int x = lo.x(); x <= hi.x(); ++x) {
        const Eigen::Vector3d centre =
            (Eigen::Vector3d(x, y, z) + Eigen::Vector3d::Constant(0.5)) * block_size;
        if (std::abs(sdf(centre)) > reach) continue;
        VolumeBlock block;
        block.coord = Eigen::Vector3i(x, y, z);
        for (int k = 0; k < kBlockSide; ++k) {
          for (int j = 0; j < kBlockSide; ++j) {
            for (int i = 0; i < kBlockSide; ++i) {
              const Eigen::Vector3d p =
                  (Eigen::Vector3d(kBlockSide * x + i, kBlockSide * y + j, kBlockSide * z + k)) *
                  static_cast<double>(voxel_size);
              Voxel& voxel = block.voxels[voxel_index(i, j, k)];
              voxel.tsdf = static_cast<float>(std::clamp(sdf(p) / volume.truncation, -1.0, 1.0));
              voxel.weight = 1.0f;
              if (color) voxel.color = color(p);
            }
          }
        }
        volume.blocks.push_back(block);
      }
    }
  }
  return volume;
}

inline Sdf sphere_sdf(const Eigen::Vector3d& centre, double radius) {
  return [=](const Eigen::Vector3d& p) { return (p - centre).norm() - radius; };
}

/// Undirected edge -> number of triangles using it, and directed edge -> count.
struct EdgeCounts {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> undirected, directed;
};

inline EdgeCounts count_edges(const Mesh& mesh) {
  EdgeCounts counts;
  for (const auto& tri : mesh.triangles) {
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = tri[static_cast<std::size_t>(e)];
      const std::uint32_t b = tri[static_cast<std::size_t>((e + 1) % 3)];
      ++counts.directed[{a, b}];
      ++counts.undirected[{std::min(a, b), std::max(a, b)}];
    }
  }
  return counts;
}

}  // namespace imufusion::test
