// Push-constant layouts shared by the shaders and the host: valid GLSL and valid C++.
// Only 32-bit scalars, so std430 / push-constant offsets equal the C++ struct offsets.
#ifndef IMUFUSION_LAYOUTS_H
#define IMUFUSION_LAYOUTS_H

#ifdef __cplusplus
#include <cstdint>
namespace imufusion::gpu::layout {
using uint = std::uint32_t;
#endif

// depth_to_metres: raw 16-bit depth (two per uint, little-endian) -> metres, 0 = invalid.
struct DepthToMetresParams {
  uint width;
  uint height;
  float inv_depth_scale;  // metres per raw unit
  float min_depth;        // metres; depth outside [min_depth, max_depth] becomes invalid
  float max_depth;
};

// bilateral: edge-preserving smoothing of a metric depth map; invalid pixels stay invalid and
// never contribute.
struct BilateralParams {
  uint width;
  uint height;
  int radius;             // pixels: the window is (2 radius + 1)^2
  float inv_two_sigma_space_sq;  // 1 / (2 sigma_space^2), sigma_space in pixels
  float inv_two_sigma_depth_sq;  // 1 / (2 sigma_depth^2), sigma_depth in metres
};

// pyramid_down: half resolution; each output pixel averages the valid pixels of its 2x2 block
// that lie within max_jump_fraction * d_min of the block's nearest depth d_min.
struct PyramidDownParams {
  uint src_width;
  uint src_height;
  uint dst_width;
  uint dst_height;
  float max_jump_fraction;
};

// vertex_map: back-projection of a depth map through the pinhole (per pyramid level).
struct VertexMapParams {
  uint width;
  uint height;
  float fx;
  float fy;
  float cx;
  float cy;
};

// normal_map: central differences of the vertex map; invalid where a 4-neighbour is missing or
// lies across a depth jump larger than max_jump_fraction * depth.
struct NormalMapParams {
  uint width;
  uint height;
  float max_jump_fraction;
};

#ifdef __cplusplus
}  // namespace imufusion::gpu::layout
#endif
#endif  // IMUFUSION_LAYOUTS_H
