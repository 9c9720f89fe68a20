#pragma once
// What fusion into the sparse TSDF block volume reports per frame, and what a raycast of the
// model returns (Reconstructor::fuse_with_pose / track_and_fuse, Reconstructor::raycast). Poses
// are camera-to-world (T_world_camera), metres.

#include <cstdint>

#include "imufusion/types.hpp"

namespace imufusion {

/// What one integration did, and what went wrong without corrupting the volume.
struct IntegrationStats {
  std::uint32_t visible_blocks = 0;    // blocks touched by this frame and fused
  std::uint32_t allocated_blocks = 0;  // blocks in the pool after it
  std::uint32_t pool_full = 0;         // blocks touched by this frame that have no room in the
                                       // full pool, refused now or in an earlier frame (not fused)
  std::uint32_t table_full = 0;        // insertions that found no free hash slot (not fused)
  std::uint32_t out_of_range = 0;      // block coordinates beyond the key range (not fused)
};

/// A raycast of the model from a pose, at the depth image's resolution.
struct RaycastImages {
  Vec4Image vertices;  // camera frame of the pose, w = 1 where the ray hit the surface
  Vec4Image normals;   // camera frame, unit, w = 1 where valid
  ColorImage shaded;   // Lambertian shading with the light at the camera
  ColorImage color;    // the fused surface colour (black where never coloured)
};

}  // namespace imufusion
