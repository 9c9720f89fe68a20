#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// 128 invocations per workgroup (fixed: the shared array below is sized for it). The values are
// reduced through shared memory in chunks of CHUNK (8.5 KiB, within the 16 KiB every Vulkan device
// offers). No subgroup operations, no float atomics: the sum order is fixed, so results are
// deterministic for a given input.
#define GROUP 128
#define CHUNK 17
layout(local_size_x = GROUP, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 0) const uint unused_x = 1;  // the runtime's workgroup specialization slots
layout(constant_id = 1) const uint unused_y = 1;
layout(std430, set = 0, binding = 0) readonly buffer Rows { vec4 rows[]; };
layout(std430, set = 0, binding = 1) readonly buffer CurVertices { vec4 cur_vertices[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Partials { float partials[]; };
layout(push_constant) uniform Push { IcpReduceParams p; };

shared float sums[CHUNK][GROUP];

void main() {
  uint t = gl_LocalInvocationID.x;
  uint g = gl_WorkGroupID.x;
  float acc[ICP_REDUCE_VALUES];
  for (int k = 0; k < ICP_REDUCE_VALUES; ++k) acc[k] = 0.0;
  uint begin = g * p.rows_per_group;
  uint end = min(begin + p.rows_per_group, p.row_count);
  for (uint r = begin + t; r < end; r += GROUP) {
    vec4 r0 = rows[2u * r];
    vec4 r1 = rows[2u * r + 1u];
    float w = r1.w;
    if (w == 0.0) continue;
    float information = 1.0;
    if (p.noise_a > 0.0) {
      float dz = cur_vertices[r].z - p.noise_z0;
      float ratio = p.noise_a / (p.noise_a + p.noise_b * dz * dz);
      information = ratio * ratio;
    }
    acc[30] += information;
    acc[32] += 1.0;
    if (w < 0.0) continue;
    acc[31] += information;
    float a[6] = float[6](r0.x, r0.y, r0.z, r0.w, r1.x, r1.y);
    float b = r1.z;
    int k = 0;
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) acc[k++] += w * a[i] * a[j];
    }
    for (int i = 0; i < 6; ++i) acc[21 + i] += w * a[i] * b;
    acc[27] += w * b * b;
    acc[28] += 1.0;
    acc[29] += w;
  }
  for (int base = 0; base < ICP_REDUCE_VALUES; base += CHUNK) {
    int count = min(CHUNK, ICP_REDUCE_VALUES - base);
    for (int k = 0; k < count; ++k) sums[k][t] = acc[base + k];
    barrier();
    for (uint stride = GROUP / 2u; stride > 0u; stride >>= 1) {
      if (t < stride) {
        for (int k = 0; k < count; ++k) sums[k][t] += sums[k][t + stride];
      }
      barrier();
    }
    if (t < uint(count)) partials[g * ICP_PARTIAL_STRIDE + uint(base) + t] = sums[t][0];
    barrier();  // the next chunk overwrites sums
  }
}
