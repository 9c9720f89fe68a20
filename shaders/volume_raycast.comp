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
layout(push_constant) uniform Push { VolumeRaycastParams p; };

#include "volume_common.glsl"

// Voxel (tsdf, weight) and colour at offset i inside pool block `block`.
vec2 voxel_in_block(uint block, ivec3 i, out uint color) {
  uint index = block * uint(VOLUME_BLOCK_VOXELS) + uint(i.x + VOLUME_BLOCK_SIDE * (i.y + VOLUME_BLOCK_SIDE * i.z));
  uint word0 = tsdf_weight[index];
  color = voxel_colors[index];
  return vec2(unpack_tsdf(word0), float(unpack_weight(word0)));
}

// The voxel at lattice point l: (tsdf, weight), weight 0 when unallocated or unobserved.
vec2 voxel_at(ivec3 l, out uint color) {
  ivec3 b = ivec3(floor(vec3(l) / float(VOLUME_BLOCK_SIDE)));
  uint block = find_block(b, p.hash_mask);
  color = 0u;
  if (block == VOLUME_NO_BLOCK) return vec2(1.0, 0.0);
  return voxel_in_block(block, l - b * VOLUME_BLOCK_SIDE, color);
}

// Trilinear TSDF at world point w; false when a corner is unobserved. The 8 corners usually lie
// in one block (343 of 512 cells): then the block is looked up once.
bool sample_tsdf(vec3 w, out float tsdf, out vec3 rgb) {
  vec3 g = w / p.voxel_size;
  ivec3 base = ivec3(floor(g));
  vec3 f = g - vec3(base);
  tsdf = 0.0;
  rgb = vec3(0.0);
  ivec3 b = ivec3(floor(vec3(base) / float(VOLUME_BLOCK_SIDE)));
  ivec3 local = base - b * VOLUME_BLOCK_SIDE;
  bool one_block = all(lessThan(local, ivec3(VOLUME_BLOCK_SIDE - 1)));
  uint block = one_block ? find_block(b, p.hash_mask) : VOLUME_NO_BLOCK;
  if (one_block && block == VOLUME_NO_BLOCK) return false;
  for (int c = 0; c < 8; ++c) {
    ivec3 o = ivec3(c & 1, (c >> 1) & 1, c >> 2);
    uint packed_color;
    vec2 v = one_block ? voxel_in_block(block, local + o, packed_color) : voxel_at(base + o, packed_color);
    if (v.y <= 0.0) return false;
    vec3 s = mix(1.0 - f, f, vec3(o));
    float weight = s.x * s.y * s.z;
    tsdf += weight * v.x;
    rgb += weight * unpackUnorm4x8(packed_color).rgb;
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
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);
  vec3 origin = vec3(p.tx, p.ty, p.tz);
  vec3 ray_c = vec3((float(px.x) - p.cx) / p.fx, (float(px.y) - p.cy) / p.fy, 1.0);
  float ray_scale = length(ray_c);  // metres along the ray per metre of depth
  vec3 dir = R * (ray_c / ray_scale);
  float block_length = p.voxel_size * float(VOLUME_BLOCK_SIDE);
  float t = p.near_depth * ray_scale;
  float t_far = p.far_depth * ray_scale;
  float previous_tsdf = 0.0;
  float previous_t = 0.0;
  bool have_previous = false;
  float hit_t = -1.0;
  while (t < t_far) {
    vec3 w = origin + t * dir;
    ivec3 b = ivec3(floor(w / block_length));
    if (find_block(b, p.hash_mask) == VOLUME_NO_BLOCK) {
      have_previous = false;
      t += 0.5 * block_length;
      continue;
    }
    float tsdf;
    vec3 rgb;
    if (!sample_tsdf(w, tsdf, rgb)) {
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
    ok = ok && sample_tsdf(hit + e, plus, unused) && sample_tsdf(hit - e, minus, unused);
    gradient[axis] = plus - minus;
  }
  float tsdf_hit;
  vec3 rgb_hit;
  if (!ok || length(gradient) <= 0.0 || !sample_tsdf(hit, tsdf_hit, rgb_hit)) {
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
