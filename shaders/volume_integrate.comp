#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// One workgroup per visible block: invocation (i, j) updates the column of voxels (i, j, 0..7).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(constant_id = 0) const uint unused_x = 8;  // the runtime's workgroup specialization slots
layout(constant_id = 1) const uint unused_y = 8;
layout(std430, set = 0, binding = 0) readonly buffer Depth { float depth[]; };  // metres
layout(std430, set = 0, binding = 1) readonly buffer Color { uint color[]; };   // RGBA8
layout(std430, set = 0, binding = 2) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 3) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 4) readonly buffer Visible { uint visible[]; };
layout(std430, set = 0, binding = 5) buffer TsdfWeight { uint tsdf_weight[]; };
layout(std430, set = 0, binding = 6) buffer Colors { uint colors[]; };
layout(std430, set = 0, binding = 7) buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { VolumeIntegrateParams p; };

#include "volume_common.glsl"

void main() {
  if (counters[VOLUME_COUNTER_ALLOCATED] > p.defer_above) return;
  uint entry = gl_WorkGroupID.x + gl_NumWorkGroups.x * gl_WorkGroupID.y;
  if (entry >= counters[VOLUME_COUNTER_VISIBLE]) return;
  uint slot = visible[entry];
  uint block = values[slot];
  if (block == VOLUME_NO_BLOCK) {  // touched, but refused storage when the pool filled
    if (gl_LocalInvocationIndex == 0u) atomicAdd(counters[VOLUME_COUNTER_POOL_FULL], 1u);
    return;
  }
  ivec3 b = unpack_key(keys[slot]);
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);
  vec3 t = vec3(p.tx, p.ty, p.tz);
  ivec2 ij = ivec2(gl_LocalInvocationID.xy);
  for (int k = 0; k < VOLUME_BLOCK_SIDE; ++k) {
    ivec3 lattice = b * VOLUME_BLOCK_SIDE + ivec3(ij, k);
    vec3 pc = R * (vec3(lattice) * p.voxel_size) + t;
    if (pc.z <= 0.0) continue;
    float u = floor(p.fx * pc.x / pc.z + p.cx + 0.5);
    float v = floor(p.fy * pc.y / pc.z + p.cy + 0.5);
    if (u < 0.0 || v < 0.0 || u >= float(p.width) || v >= float(p.height)) continue;
    uint pixel = uint(v) * p.width + uint(u);
    float d = depth[pixel];
    if (d <= 0.0) continue;
    float sdf = d - pc.z;
    if (sdf < -p.truncation) continue;
    float tsdf = min(1.0, sdf / p.truncation);
    uint index = (block * uint(VOLUME_BLOCK_VOXELS) + uint(ij.x + VOLUME_BLOCK_SIDE * (ij.y + VOLUME_BLOCK_SIDE * k)));
    uint word0 = tsdf_weight[index];
    uint weight = unpack_weight(word0);
    float old_tsdf = unpack_tsdf(word0);
    float new_tsdf = (old_tsdf * float(weight) + tsdf) / float(weight + 1u);
    uint new_weight = min(weight + 1u, p.max_weight);
    tsdf_weight[index] = pack_voxel_word0(new_tsdf, new_weight);
    if (p.has_color != 0u) {
      vec3 old_rgb = unpackUnorm4x8(colors[index]).rgb;
      vec3 rgb = unpackUnorm4x8(color[pixel]).rgb;
      vec3 mixed = (old_rgb * float(weight) + rgb) / float(weight + 1u);
      colors[index] = packUnorm4x8(vec4(mixed, 0.0));
    }
  }
}
