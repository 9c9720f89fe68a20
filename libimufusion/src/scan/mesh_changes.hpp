#pragma once
// The incremental mesh (Reconstructor::extract_mesh_changes): which blocks' pieces a viewer holds,
// and since which integration, so that a call re-meshes only the blocks fused since the last one.

#include <cstdint>
#include <optional>
#include <unordered_set>

#include "gpu/volume.hpp"
#include "imufusion/mesh.hpp"

namespace imufusion {

class MeshChangeTracker {
 public:
  /// The pieces of the blocks whose cells read voxels that integrations changed since the last
  /// call (a block touched by an integration, and its 26 neighbours), and the blocks whose piece
  /// became empty. Everything on the first call, after the volume's reset() and when the options
  /// change. On an error the next call starts over with everything.
  Result<MeshUpdate> extract(const gpu::TsdfVolume& volume, const MeshOptions& options);

 private:
  // The blocks to re-mesh: those the integrations since `since_stamp` touched and their neighbours,
  // plus every reported block on a full update.
  std::vector<Eigen::Vector3i> dirty_blocks(const std::vector<gpu::TsdfVolume::BlockEntry>& entries,
                                            bool full) const;

  bool started_ = false;
  std::uint64_t epoch_ = 0;        // the volume's epoch at the last call
  std::uint32_t since_stamp_ = 0;  // the volume's frame stamp at the last call
  std::optional<MeshOptions> options_;
  std::unordered_set<std::uint64_t> reported_;  // block keys whose piece the viewer holds
};

}  // namespace imufusion
