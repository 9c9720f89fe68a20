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

// icp_associate: projective data association for point-to-plane ICP at one pyramid level.
// Each current-frame pixel with a vertex v and normal n is moved by the estimate T_ref_cur
// (p = R v + t, m = R n), projected into the reference maps and paired with the reference vertex
// q and normal g there. The pair is rejected when either is invalid, the projection falls outside
// the reference image, |p - q| > max_distance, or m . g < min_normal_cos. Otherwise it writes the
// linearized point-to-plane row (Low 2004, small-angle rotation x = (alpha, beta, gamma, tx, ty,
// tz)): a = (p x g, g), b = g . (q - p), and the weight
//     w = (m . g) * (1 - |p - q| / max_distance)
// (normal agreement times distance agreement, both in (0, 1]).
struct IcpAssociateParams {
  uint width;       // current level size
  uint height;
  uint ref_width;   // reference level size
  uint ref_height;
  float fx;         // reference intrinsics at this level, pixels
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_ref_cur, row-major 3x4, metres
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float max_distance;    // metres
  float min_normal_cos;  // cosine of the largest normal angle
};

// icp_reduce: the first stage of a deterministic two-stage reduction over the association rows.
// Workgroup g sums rows [g * rows_per_group, (g + 1) * rows_per_group) into ICP_PARTIAL_STRIDE
// floats: the 21 upper-triangle entries of sum w a a^T (row-major), the 6 of sum w a b, sum w b^2,
// the inlier count, the weight sum and the count of current pixels with a vertex and a normal
// (rows with w != 0: association writes w = -1 for such a pixel whose pair it rejected).
// The host adds the partials in double.
#define ICP_REDUCE_VALUES 31
#define ICP_PARTIAL_STRIDE 32
#define ICP_ROW_FLOATS 8
struct IcpReduceParams {
  uint row_count;
  uint rows_per_group;
};

#ifdef __cplusplus
}  // namespace imufusion::gpu::layout
#endif
#endif  // IMUFUSION_LAYOUTS_H
