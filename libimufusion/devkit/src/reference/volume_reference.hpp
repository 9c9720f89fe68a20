#pragma once
// CPU reference of the sparse TSDF volume kernels (shaders/volume_allocate.comp,
// volume_integrate.comp, volume_raycast.comp), written in double from their definitions in
// shaders/include/imufusion_layouts.h and the geometry of imufusion/volume.hpp. Blocks live in an
// unordered_map (no hash table, no pool: nothing can overflow here), voxels are quantized as the
// GPU stores them: tsdf as int16 (truncation units * 32767, rounded), an integer weight and 8-bit
// colour, so that a GPU snapshot loads without loss and the two can be compared voxel by voxel.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "imufusion/fusion.hpp"
#include "imufusion/types.hpp"
#include "imufusion/volume.hpp"

namespace imufusion::reference {

struct BlockCoordHash {
  std::size_t operator()(const Eigen::Vector3i& b) const;
};

/// A voxel as stored: tsdf * 32767 (truncation units), observation count, colour.
struct StoredVoxel {
  std::int16_t tsdf = 0;
  std::uint16_t weight = 0;
  std::array<std::uint8_t, 3> color = {0, 0, 0};
};
using StoredBlock = std::array<StoredVoxel, kBlockVoxels>;

/// Block coordinates that a block key can hold: x, y in [-1024, 1023], z in [-512, 511], except
/// (1023, 1023, 511), whose key would be the empty-slot marker.
bool block_in_key_range(const Eigen::Vector3i& b);

/// What one allocation did: the blocks the frame touches (in key range, each once, sorted by
/// (x, y, z)) and how many block coordinates were outside the key range (each crossing counted
/// once per pixel, as the GPU counts them).
struct AllocationResult {
  std::vector<Eigen::Vector3i> visible;
  std::uint64_t out_of_range = 0;
};

/// The blocks crossed by every valid pixel's ray segment from max(d - truncation, 0) to
/// d + truncation (d = depth in metres, the ray scaled to unit z), sampled every half block.
AllocationResult visible_blocks(const FloatImage& depth, const Intrinsics& intrinsics,
                                const Eigen::Isometry3d& T_world_camera, double voxel_size,
                                double truncation);

class CpuVolume {
 public:
  /// voxel_size and truncation in metres; max_weight caps the running average's weight.
  CpuVolume(double voxel_size, double truncation, int max_weight);
  explicit CpuVolume(const VolumeConfig& config);
  /// A volume holding exactly the blocks of `host` (a GPU snapshot), quantized back losslessly.
  static CpuVolume from_host_volume(const HostVolume& host, int max_weight);

  /// Inserts the frame's visible blocks that are not allocated yet (depth in metres, 0 =
  /// invalid) and returns the allocation (the visible set).
  AllocationResult allocate(const FloatImage& depth, const Intrinsics& intrinsics,
                            const Eigen::Isometry3d& T_world_camera);
  /// Fuses the frame into `blocks` (those not allocated are ignored). `color` (RGB8, the depth's
  /// size) is averaged too when given.
  void integrate(const FloatImage& depth, const ColorImage* color, const Intrinsics& intrinsics,
                 const Eigen::Isometry3d& T_world_camera,
                 const std::vector<Eigen::Vector3i>& blocks);
  /// allocate() then integrate() of the visible blocks; returns the allocation.
  AllocationResult fuse(const FloatImage& depth, const ColorImage* color,
                        const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera);

  /// March every pixel's ray from near_depth to far_depth (metres of z-depth) by the rule of
  /// shaders/include/volume_raycast_rule.h and return the camera-frame vertex and normal maps,
  /// the shading and the fused colour at the hit. The GPU
  /// kernel marches only within a range image of the allocated blocks, where the full march can
  /// meet a block; that shortens the march without changing its samples, so this is the full one.
  RaycastImages raycast(const Intrinsics& intrinsics, const Eigen::Isometry3d& T_world_camera,
                        double near_depth, double far_depth) const;

  HostVolume to_host_volume() const;

  /// Adds an empty block (all voxels unobserved); no-op when it exists.
  void add_block(const Eigen::Vector3i& b);
  bool contains(const Eigen::Vector3i& b) const { return blocks_.count(b) != 0; }
  std::size_t block_count() const { return blocks_.size(); }
  /// The voxel at lattice point l (world point l * voxel_size), nullptr when unallocated.
  const StoredVoxel* voxel(const Eigen::Vector3i& l) const;
  /// All block coordinates, sorted by (x, y, z).
  std::vector<Eigen::Vector3i> block_coords() const;

  double voxel_size() const { return voxel_size_; }
  double truncation() const { return truncation_; }

 private:
  /// Trilinear TSDF (truncation units) and, when rgb is given, colour (0..1) at lattice
  /// coordinates g (world point / voxel_size); false when one of the 8 surrounding lattice
  /// points is unobserved.
  bool trilinear(const Eigen::Vector3d& g, double* tsdf, Eigen::Vector3d* rgb) const;
  /// Distance (metres) along the ray from `origin` along unit `dir` (world frame) to its first
  /// crossing from positive to non-positive TSDF, marched from t to t_far; -1 when none.
  double march_ray(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t,
                   double t_far) const;
  /// The TSDF gradient (world frame, unnormalized) and colour (0..1) at world point `hit`;
  /// false where a sample is unobserved or the gradient vanishes.
  bool surface_at(const Eigen::Vector3d& hit, Eigen::Vector3d* gradient,
                  Eigen::Vector3d* rgb) const;

  double voxel_size_;
  double truncation_;
  int max_weight_;
  std::unordered_map<Eigen::Vector3i, StoredBlock, BlockCoordHash> blocks_;
};

/// Sort order used for block lists: lexicographic (x, y, z).
bool block_less(const Eigen::Vector3i& a, const Eigen::Vector3i& b);

}  // namespace imufusion::reference
