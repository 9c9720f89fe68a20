#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// The z-depth interval of the allocated blocks over each tile of the raycast image, so that a
// ray marches only where a block can be (see VolumeRangeParams).
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 2) readonly buffer BlockSlots { uint block_slots[]; };
layout(std430, set = 0, binding = 3) buffer Range { uint range[]; };
layout(std430, set = 0, binding = 4) readonly buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { VolumeRangeParams p; };

#include "volume_common.glsl"

// Bounds of the block part at z >= near: z-depth (metres) and projected pixel coordinates.
float z_lo = 1.0e30, z_hi = -1.0e30;
vec2 uv_lo = vec2(1.0e30), uv_hi = vec2(-1.0e30);

void include_point(vec3 q) {
  z_lo = min(z_lo, q.z);
  z_hi = max(z_hi, q.z);
  vec2 uv = vec2(p.fx * q.x / q.z + p.cx, p.fy * q.y / q.z + p.cy);
  uv_lo = min(uv_lo, uv);
  uv_hi = max(uv_hi, uv);
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= min(counters[VOLUME_COUNTER_ALLOCATED], p.pool_blocks)) return;
  ivec3 b = unpack_key(keys[block_slots[i]]);
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);
  vec3 t = vec3(p.tx, p.ty, p.tz);
  float block_length = p.voxel_size * float(VOLUME_BLOCK_SIDE);
  vec3 origin = R * (vec3(b) * block_length) + t;
  vec3 corners[8];
  for (int c = 0; c < 8; ++c)
    corners[c] = origin + R * (block_length * vec3(c & 1, (c >> 1) & 1, c >> 2));
  // The clipping plane: rays start at z = near; a plane at z = 0 would divide by zero.
  const float kMinClip = 1.0e-3;  // metres
  float clip = max(p.near_depth, kMinClip);
  bool whole_image = false;
  for (int c = 0; c < 8; ++c) {
    if (corners[c].z >= clip) {
      include_point(corners[c]);
    } else if (corners[c].z >= p.near_depth) {
      whole_image = true;  // a part between near (< 1 mm) and the clip plane: no finite bounds
    }
    // The edges from this corner to its neighbours with a higher index, where they cross the
    // clipping plane (the part of a convex block at z >= clip is spanned by these points).
    for (int axis = 0; axis < 3; ++axis) {
      int n = c | (1 << axis);
      if (n == c) continue;
      float za = corners[c].z - clip, zb = corners[n].z - clip;
      if ((za < 0.0) != (zb < 0.0)) {
        vec3 q = mix(corners[c], corners[n], za / (za - zb));
        include_point(vec3(q.xy, clip));
      }
    }
  }
  if (whole_image) {
    z_lo = p.near_depth;
    z_hi = max(z_hi, clip);
    uv_lo = vec2(0.0);
    uv_hi = vec2(float(p.width - 1u), float(p.height - 1u));
  }
  if (z_hi < z_lo) return;  // entirely in front of the near plane
  // Pixel centres within the box, widened by a pixel against rounding.
  ivec2 lo = ivec2(max(floor(uv_lo) - 1.0, vec2(0.0)));
  ivec2 hi = ivec2(min(ceil(uv_hi) + 1.0, vec2(float(p.width - 1u), float(p.height - 1u))));
  if (uv_hi.x < -1.0 || uv_hi.y < -1.0 || uv_lo.x > float(p.width) || uv_lo.y > float(p.height)) return;
  uint lo_bits = ~floatBitsToUint(max(z_lo - 0.5 * p.voxel_size, 0.0));
  uint hi_bits = floatBitsToUint(z_hi + 0.5 * p.voxel_size);
  ivec2 cell_lo = lo / VOLUME_RANGE_TILE, cell_hi = hi / VOLUME_RANGE_TILE;
  for (int y = cell_lo.y; y <= cell_hi.y; ++y) {
    for (int x = cell_lo.x; x <= cell_hi.x; ++x) {
      uint cell = uint(y) * p.range_width + uint(x);
      atomicMax(range[2u * cell], lo_bits);
      atomicMax(range[2u * cell + 1u], hi_bits);
    }
  }
}
