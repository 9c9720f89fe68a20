#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 2) readonly buffer TsdfWeight { uint tsdf_weight[]; };
layout(std430, set = 0, binding = 3) readonly buffer VoxelColors { uint voxel_colors[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Vertices { vec4 vertices[]; };  // camera frame
layout(std430, set = 0, binding = 5) writeonly buffer Normals { vec4 normals[]; };    // camera frame
layout(std430, set = 0, binding = 6) writeonly buffer Shaded { uint shaded[]; };      // RGBA8
layout(std430, set = 0, binding = 7) writeonly buffer Colors { uint colors[]; };      // RGBA8
layout(std430, set = 0, binding = 8) readonly buffer Range { uint range[]; };  // volume_raycast_range
layout(std430, set = 0, binding = 9) writeonly buffer Steps { uint steps[]; };  // march steps per ray
layout(push_constant) uniform Push { VolumeRaycastParams p; };

#include "volume_common.glsl"

// The packed (tsdf, weight) word and its colour of the voxel at lattice point l, in pool block
// `block` of block coordinate b, or in the block that holds l when it is not b.
uint voxel_word(ivec3 l, ivec3 b, uint block, out uint index) {
  ivec3 lb = l >> 3;  // floor(l / VOLUME_BLOCK_SIDE)
  if (lb != b) block = find_block(lb, p.hash_mask);
  if (block == VOLUME_NO_BLOCK) return 0u;  // weight 0: unobserved
  ivec3 i = l - lb * VOLUME_BLOCK_SIDE;
  index = block * uint(VOLUME_BLOCK_VOXELS) + uint(i.x + VOLUME_BLOCK_SIDE * (i.y + VOLUME_BLOCK_SIDE * i.z));
  return tsdf_weight[index];
}

// Trilinear TSDF at world point w (and the colour when with_color); false when a corner is
// unobserved. `block` is the pool block of the block that holds floor(w / voxel_size), or
// VOLUME_NO_BLOCK to look it up: the 8 corners usually lie in it (343 of 512 cells), and only
// corners in a neighbouring block cost a lookup.
bool sample_tsdf(vec3 w, uint block, bool with_color, out float tsdf, out vec3 rgb) {
  vec3 g = w / p.voxel_size;
  ivec3 base = ivec3(floor(g));
  vec3 f = g - vec3(base);
  ivec3 b = base >> 3;
  if (block == VOLUME_NO_BLOCK) block = find_block(b, p.hash_mask);
  tsdf = 0.0;
  rgb = vec3(0.0);
  if (block == VOLUME_NO_BLOCK) return false;
  for (int c = 0; c < 8; ++c) {
    ivec3 o = ivec3(c & 1, (c >> 1) & 1, c >> 2);
    uint index;
    uint word0 = voxel_word(base + o, b, block, index);
    if (unpack_weight(word0) == 0u) return false;
    vec3 s = mix(1.0 - f, f, vec3(o));
    float weight = s.x * s.y * s.z;
    tsdf += weight * unpack_tsdf(word0);
    if (with_color) rgb += weight * unpackUnorm4x8(voxel_colors[index]).rgb;
  }
  return true;
}

void write_miss(uint i) {
  vertices[i] = vec4(0.0);
  normals[i] = vec4(0.0);
  shaded[i] = 0u;
  colors[i] = 0u;
}

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = px.y * p.width + px.x;
  uint cell = (px.y / uint(VOLUME_RANGE_TILE)) * p.range_width + px.x / uint(VOLUME_RANGE_TILE);
  uint lo_bits = range[2u * cell];
  if (lo_bits == 0u) {  // no allocated block projects here
    write_miss(i);
    steps[i] = 0u;
    return;
  }
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);
  vec3 origin = vec3(p.tx, p.ty, p.tz);
  vec3 ray_c = vec3((float(px.x) - p.cx) / p.fx, (float(px.y) - p.cy) / p.fy, 1.0);
  float ray_scale = length(ray_c);  // metres along the ray per metre of depth
  vec3 dir = R * (ray_c / ray_scale);
  float block_length = p.voxel_size * float(VOLUME_BLOCK_SIDE);
  float skip = 0.5 * block_length;
  float t_near = p.near_depth * ray_scale;
  // The full march from t_near steps `skip` at a time through unallocated blocks, and every
  // block on this ray lies within the cell's range: start at its last step before the range and
  // stop past the range (see VolumeRangeParams).
  float t_range_lo = uintBitsToFloat(~lo_bits) * ray_scale;
  float t_range_hi = uintBitsToFloat(range[2u * cell + 1u]) * ray_scale;
  float t = t_near + max(floor((t_range_lo - t_near) / skip), 0.0) * skip;
  float t_far = min(p.far_depth * ray_scale, t_range_hi);
  float previous_tsdf = 0.0;
  float previous_t = 0.0;
  bool have_previous = false;
  float hit_t = -1.0;
  uint step_count = 0u;
  while (t < t_far) {
    ++step_count;
    vec3 w = origin + t * dir;
    uint block = find_block(ivec3(floor(w / p.voxel_size)) >> 3, p.hash_mask);
    if (block == VOLUME_NO_BLOCK) {
      have_previous = false;
      t += skip;
      continue;
    }
    float tsdf;
    vec3 unused;
    if (!sample_tsdf(w, block, false, tsdf, unused)) {
      have_previous = false;
      t += 0.5 * p.voxel_size;
      continue;
    }
    if (have_previous && previous_tsdf > 0.0 && tsdf <= 0.0) {
      hit_t = previous_t + (t - previous_t) * previous_tsdf / (previous_tsdf - tsdf);
      break;
    }
    previous_tsdf = tsdf;
    previous_t = t;
    have_previous = true;
    t += max(0.8 * tsdf * p.truncation, 0.5 * p.voxel_size);
  }
  steps[i] = step_count;
  if (hit_t < 0.0) {
    write_miss(i);
    return;
  }
  vec3 hit = origin + hit_t * dir;
  // Normal: central differences of the trilinear TSDF, one voxel apart.
  vec3 gradient;
  vec3 unused;
  float plus, minus;
  bool ok = true;
  for (int axis = 0; axis < 3; ++axis) {
    vec3 e = vec3(0.0);
    e[axis] = p.voxel_size;
    ok = ok && sample_tsdf(hit + e, VOLUME_NO_BLOCK, false, plus, unused) &&
         sample_tsdf(hit - e, VOLUME_NO_BLOCK, false, minus, unused);
    gradient[axis] = plus - minus;
  }
  float tsdf_hit;
  vec3 rgb_hit;
  if (!ok || length(gradient) <= 0.0 || !sample_tsdf(hit, VOLUME_NO_BLOCK, true, tsdf_hit, rgb_hit)) {
    write_miss(i);
    return;
  }
  vec3 n_world = normalize(gradient);
  mat3 Rt = transpose(R);
  vec3 hit_c = Rt * (hit - origin);
  vec3 n_c = Rt * n_world;
  vertices[i] = vec4(hit_c, 1.0);
  normals[i] = vec4(n_c, 1.0);
  float lambert = max(0.0, dot(n_c, -normalize(hit_c)));
  shaded[i] = packUnorm4x8(vec4(vec3(0.15 + 0.85 * lambert), 1.0));
  colors[i] = packUnorm4x8(vec4(rgb_hit, 1.0));
}
