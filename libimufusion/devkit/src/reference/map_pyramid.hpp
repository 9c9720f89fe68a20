#pragma once
// The host reference of the GPU's map pyramid (shaders/map_pyramid_down.comp): pyramids of
// vertex and normal maps given at full resolution (e.g. a raycast of the model), built with the
// rule of the depth pyramid (shaders/pyramid_down.comp): each coarser pixel
// averages the valid entries of its 2x2 block whose depth lies within max_jump_fraction of the
// block's nearest depth; normals are averaged and renormalized.

#include <vector>

#include "imufusion/types.hpp"

namespace imufusion {

struct MapLevel {
  Vec4Image vertices;
  Vec4Image normals;
};

/// Level 0 is the input; each further level halves the size (odd sizes round down).
std::vector<MapLevel> build_map_pyramid(const Vec4Image& vertices, const Vec4Image& normals,
                                        int levels, float max_jump_fraction);

}  // namespace imufusion
