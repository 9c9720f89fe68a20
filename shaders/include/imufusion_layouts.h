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
// the reference image, |p - q| > max_distance, or m . g is below the pixel's normal cosine
// (min_normal_cos, lowered where the depth noise makes normals scatter). Otherwise it writes the
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
  // The normal test widened to the depth noise (imufusion::NormalGate): a pixel at depth z
  // (current frame) passes down to min(min_normal_cos, cos atan(noise_k sigma(z) fx / z)), never
  // below max_noise_cos; sigma(z) = noise_a + noise_b (z - noise_z0)^2.
  float noise_a;  // metres
  float noise_b;  // 1 / metre
  float noise_z0; // metres
  float noise_k;
  float max_noise_cos;
};

// icp_photometric: the photometric rows of ICP at one pyramid level, in icp_associate's row
// format. Each current pixel with a vertex v is moved by T_ref_cur (p = R v + t) and projected
// into the reference at subpixel (u, v). Where the reference's vertices at the 2x2 cell around it
// and at their 4-neighbours are valid and within max_distance of p in depth, the row linearizes
// I_ref(pi(p)) - I_cur: a = (p x g, g) with g the reference intensity's bilinear gradient times the
// projection's Jacobian, b = I_cur - I_ref(u, v). Intensities are the Rec. 601 luma of the RGBA8
// colours in [0, 1]; the current one is the mean over the 2^color_shift square of full-resolution
// colour pixels the level pixel covers. w = 1, Huber-weighted beyond `huber`; w = 0 without a
// vertex, -1 where rejected.
struct IcpPhotometricParams {
  uint width;       // current level size
  uint height;
  uint ref_width;   // reference level size (its vertices and colours)
  uint ref_height;
  float fx;         // reference intrinsics at this level, pixels
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_ref_cur, row-major 3x4, metres
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float max_distance;  // metres
  uint color_width;    // the current colour's width (full resolution)
  uint color_shift;    // log2 of the level's downsampling from the current colour
  float huber;         // intensity
  uint step;           // every step-th pixel in x and y; row (y / step) * ceil(width / step) + x / step
};

// icp_reduce: the first stage of a deterministic two-stage reduction over the association rows.
// Workgroup g sums rows [g * rows_per_group, (g + 1) * rows_per_group) into ICP_PARTIAL_STRIDE
// floats: the 21 upper-triangle entries of sum w a a^T (row-major), the 6 of sum w a b, sum w b^2,
// the inlier count, the weight sum, and the sums of the depth noise information
// (noise_a / sigma(z))^2, sigma(z) = noise_a + noise_b (z - noise_z0)^2 (1 when noise_a = 0), of
// the current vertex over the current pixels with a vertex and a normal (rows with w != 0:
// association writes w = -1 for such a pixel whose pair it rejected) and over the paired ones,
// the number of those valid pixels, and the information and number of the valid pixels the
// reference does not cover (w = -2). The host adds the partials in double.
#define ICP_REDUCE_VALUES 35
#define ICP_PARTIAL_STRIDE 35
#define ICP_ROW_FLOATS 8
struct IcpReduceParams {
  uint row_count;
  uint rows_per_group;
  float noise_a;  // metres
  float noise_b;  // 1 / metre
  float noise_z0; // metres
};

// The sparse TSDF volume (see libimufusion/include/imufusion/volume.hpp for the geometry).
// Hash table: `hash_slots` slots of (key, pool index, visibility stamp); open addressing with
// linear probing of at most VOLUME_MAX_PROBES slots; keys are inserted with atomicCompSwap only.
// A key packs a block coordinate: x, y in [-1024, 1023] (11 bits each), z in [-512, 511] (10 bits),
// except (1023, 1023, 511), whose key would be VOLUME_EMPTY_KEY (it counts as out of range).
// Voxels: 8 bytes each, block-major, in two pool arrays of one uint per voxel (so that each
// binding stays within the 128 MiB maxStorageBufferRange that every Vulkan device offers for
// 2^16 blocks): tsdf_weight = int16 tsdf (truncation units * 32767) | uint16 weight << 16, and
// colors = r | g << 8 | b << 16.
#define VOLUME_EMPTY_KEY 0xFFFFFFFFu
#define VOLUME_NO_BLOCK 0xFFFFFFFFu
#define VOLUME_MAX_PROBES 64
#define VOLUME_BLOCK_SIDE 8
#define VOLUME_BLOCK_VOXELS 512
// counters[]: what the allocation and integration passes report.
#define VOLUME_COUNTER_ALLOCATED 0     // pool blocks handed out (may exceed capacity: overflow)
#define VOLUME_COUNTER_VISIBLE 1       // hash slots the frame touched (visible list entries)
#define VOLUME_COUNTER_POOL_FULL 2     // of those, blocks without pool storage (counted by integrate)
#define VOLUME_COUNTER_TABLE_FULL 3    // insertions that found no free slot within the probes
#define VOLUME_COUNTER_OUT_OF_RANGE 4  // block coordinates outside the key range
#define VOLUME_COUNTERS 8

// volume_allocate: per depth pixel, the blocks crossed by the ray segment within +-truncation of
// the measured depth (sampled every half block along the segment) are inserted, and each hash
// slot touched is appended once per frame (visibility stamp) to the visible list, which has one
// entry per hash slot: a slot whose block found no pool storage is listed too, so no race with
// its inserter can push a stored block off the list. The inserter of a block that got pool index
// i writes block_slots[i] = its slot (i < max_blocks); the block has storage when i < pool_blocks,
// and otherwise keeps VOLUME_NO_BLOCK until the pool grows (volume_pool_grow).
struct VolumeAllocateParams {
  uint width;
  uint height;
  float fx;
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_world_camera, row-major 3x4, metres
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float voxel_size;   // metres
  float truncation;   // metres
  uint hash_mask;     // hash_slots - 1
  uint pool_blocks;   // blocks the pool holds now
  uint frame_stamp;   // > 0, new every frame
  uint max_blocks;    // blocks the pool may grow to (block_slots entries)
};

// volume_dispatch_args: one invocation turns the counters into the workgroup counts of the
// dispatches that follow on the GPU (VkDispatchIndirectCommand, 4 uints each, at these indices):
// integration, one group per visible-list entry on a 2-D grid at most
// VOLUME_INTEGRATE_GROUPS_X wide; the range pass, one invocation per pool block in use.
#define VOLUME_ARGS_INTEGRATE 0
#define VOLUME_ARGS_RANGE 4
#define VOLUME_ARGS_WORDS 8
#define VOLUME_INTEGRATE_GROUPS_X 32768
#define VOLUME_RANGE_GROUP 64
struct VolumeArgsParams {
  uint pool_blocks;  // blocks the pool holds now
};

// volume_integrate: one workgroup per visible-list entry (counters[VOLUME_COUNTER_VISIBLE]; a
// listed slot without pool storage only counts VOLUME_COUNTER_POOL_FULL) (a 2-D grid of groups,
// entry = x + width * y, so more blocks than maxComputeWorkGroupCount[0] can be visible); each voxel is projected into the depth
// image (camera pose T_camera_world), sdf = depth - z, skipped below -truncation, then
// tsdf = min(1, sdf / truncation) enters a running average with the weight capped at max_weight.
struct VolumeIntegrateParams {
  uint width;
  uint height;
  float fx;
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_camera_world, row-major 3x4
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float voxel_size;
  float truncation;
  uint max_weight;
  uint has_color;    // 1: colour (RGBA8 per pixel) is bound and averaged too
  uint defer_above;  // when the frame left more blocks allocated than this (a pool that can still
                     // grow overflowed), nothing is fused: the pool grows and the frame is redone
};

// volume_pool_grow: after the pool grew to hold blocks [first, first + count) that a frame was
// refused, each such block's hash slot (block_slots[i]) gets its pool index i.
struct VolumePoolGrowParams {
  uint first;
  uint count;
};

// volume_raycast_range: one invocation per pool block in use (block_slots[0..n), n the allocation
// counter capped at pool_blocks): the part of
// the block at z >= near_depth is projected with the raycast pose, and every range cell (a tile
// of VOLUME_RANGE_TILE^2 pixels) whose pixel centres its bounding box may cover gets the block's
// z-depth interval (widened by half a voxel). range[2 c] = max over blocks of ~bits(z_min) (0:
// no block), range[2 c + 1] = max of bits(z_max): positive floats order as their bits, so the
// buffer starts zeroed and only atomicMax is used.
#define VOLUME_RANGE_TILE 8
struct VolumeRangeParams {
  uint width;   // raycast image, pixels
  uint height;
  float fx;
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_camera_world, row-major 3x4
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float voxel_size;
  float near_depth;   // metres of z-depth
  uint range_width;   // cells per row: ceil(width / VOLUME_RANGE_TILE)
  uint pool_blocks;   // blocks the pool holds now
};

// volume_raycast: per pixel, march the ray from near to far by the rule of
// volume_raycast_rule.h: unallocated blocks are left through their exit face, observed space is
// crossed in steps bounded by the nearest voxel's TSDF, and the first + to - crossing of the
// trilinear TSDF is refined linearly. The range image only shortens the march: it starts at the
// cell's z_min and ends past its z_max, outside which every sample of the full march would fall
// in unallocated blocks, so the result is that of the full march. Output (camera frame of the
// pose): vertex and normal maps (w = 1 where hit), a shaded image and the surface colour.
struct VolumeRaycastParams {
  uint width;
  uint height;
  float fx;
  float fy;
  float cx;
  float cy;
  float r00, r01, r02, tx;  // T_world_camera, row-major 3x4
  float r10, r11, r12, ty;
  float r20, r21, r22, tz;
  float voxel_size;
  float truncation;
  float near_depth;  // metres of z-depth (along the optical axis)
  float far_depth;
  uint hash_mask;
  uint range_width;  // cells per row of the range image
};

#ifdef __cplusplus
}  // namespace imufusion::gpu::layout
#endif
#endif  // IMUFUSION_LAYOUTS_H
