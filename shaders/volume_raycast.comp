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
#include "volume_raycast_rule.h"

// One-entry caches of block lookups: `home` for the block holding the sample point (consecutive
// samples mostly stay in one block), `other` for lattice points in a neighbouring block.
ivec3 home_coord = ivec3(0x7FFFFFFF);
uint home_block = VOLUME_NO_BLOCK;
ivec3 other_coord = ivec3(0x7FFFFFFF);
uint other_block = VOLUME_NO_BLOCK;

uint lookup_home(ivec3 b) {
  if (b != home_coord) {
    home_coord = b;
    home_block = find_block(b, p.hash_mask);
  }
  return home_block;
}

// The pool index of lattice point l (world point l * voxel_size), or VOLUME_NO_BLOCK when its
// block is unallocated, through the caches (home first).
uint voxel_index(ivec3 l) {
  ivec3 lb = l >> 3;  // floor(l / VOLUME_BLOCK_SIDE)
  uint block = home_block;
  if (lb != home_coord) {
    if (lb != other_coord) {
      other_coord = lb;
      other_block = find_block(lb, p.hash_mask);
    }
    block = other_block;
  }
  if (block == VOLUME_NO_BLOCK) return VOLUME_NO_BLOCK;
  ivec3 i = l & (VOLUME_BLOCK_SIDE - 1);
  return block * uint(VOLUME_BLOCK_VOXELS) + uint(i.x + VOLUME_BLOCK_SIDE * (i.y + VOLUME_BLOCK_SIDE * i.z));
}

// Trilinear TSDF (truncation units) at lattice coordinates g = w / voxel_size; false when a
// corner is unobserved. lookup_home(floor(g) >> 3) must have been called.
bool trilinear_tsdf(vec3 g, out float tsdf) {
  ivec3 base = ivec3(floor(g));
  vec3 f = g - vec3(base);
  tsdf = 0.0;
  for (int c = 0; c < 8; ++c) {
    ivec3 o = ivec3(c & 1, (c >> 1) & 1, c >> 2);
    uint index = voxel_index(base + o);
    if (index == VOLUME_NO_BLOCK) return false;
    uint word0 = tsdf_weight[index];
    if (unpack_weight(word0) == 0u) return false;
    vec3 s = mix(1.0 - f, f, vec3(o));
    tsdf += s.x * s.y * s.z * unpack_tsdf(word0);
  }
  return true;
}

// At lattice coordinates g: the central differences of the trilinear TSDF one voxel apart along
// each axis, F(g + e) - F(g - e) (truncation units), and the trilinear colour; false when a
// lattice point they read is unobserved. The 6 trilinear samples read 32 distinct lattice points:
// the 8 corners of g's cell and, per axis, the 8 beyond its two faces across that axis.
bool hit_gradient_color(vec3 g, out vec3 gradient, out vec3 rgb) {
  ivec3 base = ivec3(floor(g));
  vec3 f = g - vec3(base);
  lookup_home(base >> 3);
  gradient = vec3(0.0);
  rgb = vec3(0.0);
  for (int c = 0; c < 8; ++c) {
    ivec3 o = ivec3(c & 1, (c >> 1) & 1, c >> 2);
    uint index = voxel_index(base + o);
    if (index == VOLUME_NO_BLOCK) return false;
    uint word0 = tsdf_weight[index];
    if (unpack_weight(word0) == 0u) return false;
    vec3 s = mix(1.0 - f, f, vec3(o));        // trilinear weight per axis
    vec3 d = mix(-f, 1.0 - f, vec3(o));       // its weight in F(g + e) - F(g - e) per axis
    gradient += unpack_tsdf(word0) * d * vec3(s.y * s.z, s.x * s.z, s.x * s.y);
    rgb += s.x * s.y * s.z * unpackUnorm4x8(voxel_colors[index]).rgb;
  }
  for (int c = 0; c < 24; ++c) {
    int axis = c >> 3, a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    int beyond = c & 1;  // 0: the lattice point at offset -1 along the axis, 1: at offset 2
    int j = (c >> 1) & 1, k = (c >> 2) & 1;
    ivec3 o = ivec3(0);
    o[axis] = 3 * beyond - 1;
    o[a1] = j;
    o[a2] = k;
    uint index = voxel_index(base + o);
    if (index == VOLUME_NO_BLOCK) return false;
    uint word0 = tsdf_weight[index];
    if (unpack_weight(word0) == 0u) return false;
    float across = (j == 1 ? f[a1] : 1.0 - f[a1]) * (k == 1 ? f[a2] : 1.0 - f[a2]);
    float along = beyond == 1 ? f[axis] : f[axis] - 1.0;
    gradient[axis] += unpack_tsdf(word0) * along * across;
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
  float t_near = p.near_depth * ray_scale;
  // Unallocated blocks are left through their exit face, so the samples in allocated blocks do
  // not depend on where the march starts: start at the cell's range (every block on this ray
  // lies within it, see VolumeRangeParams) and stop past it.
  float t_range_lo = uintBitsToFloat(~lo_bits) * ray_scale;
  float t_range_hi = uintBitsToFloat(range[2u * cell + 1u]) * ray_scale;
  float t = max(t_near, t_range_lo);
  // Per axis, the block face a ray leaves through (0: lower, 1: upper) and 1 / direction; an
  // axis the ray runs parallel to puts its faces' t at "never" (3e38).
  vec3 exit_face = step(0.0, dir);
  vec3 inverse_dir = mix(1.0 / dir, vec3(3.0e38), lessThan(abs(dir), vec3(1.0e-12)));
  vec3 parallel_faces = mix(vec3(0.0), vec3(3.0e38), lessThan(abs(dir), vec3(1.0e-12)));
  float t_far = min(p.far_depth * ray_scale, t_range_hi);
  float previous_tsdf = 0.0;
  float previous_t = 0.0;
  bool have_previous = false;
  float coarse_distance = VOLUME_RAYCAST_COARSE_VOXELS * p.voxel_size;  // metres
  float coarse_margin = p.voxel_size;
  float hit_t = -1.0;
  uint step_count = 0u;
  while (t < t_far) {
    ++step_count;
    vec3 g = (origin + t * dir) / p.voxel_size;  // lattice coordinates of the sample
    if (lookup_home(ivec3(floor(g)) >> 3) == VOLUME_NO_BLOCK) {
      have_previous = false;
      vec3 t_faces = max((block_length * (vec3(home_coord) + exit_face) - origin) * inverse_dir, parallel_faces);
      t = max(t, min(t_faces.x, min(t_faces.y, t_faces.z))) + VOLUME_RAYCAST_EXIT_MARGIN * p.voxel_size;
      continue;
    }
    uint nearest = voxel_index(ivec3(floor(g + 0.5)));
    uint word0 = nearest == VOLUME_NO_BLOCK ? 0u : tsdf_weight[nearest];
    float tsdf = unpack_tsdf(word0);
    if (tsdf * p.truncation >= coarse_distance && unpack_weight(word0) != 0u) {
      // Far in front of the surface: a step that the nearest voxel's distance bounds.
      have_previous = false;
      t += 0.8 * tsdf * p.truncation - coarse_margin;
      continue;
    }
    if (unpack_weight(word0) == 0u || !trilinear_tsdf(g, tsdf)) {  // unobserved
      have_previous = false;
      t += (unpack_weight(word0) == 0u ? 1.0 : 0.5) * p.voxel_size;
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
  vec3 gradient, rgb_hit;
  if (!hit_gradient_color(hit / p.voxel_size, gradient, rgb_hit) || length(gradient) <= 0.0) {
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
