#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// 128 invocations per workgroup (fixed: the shared array below is sized for it). The values are
// reduced through shared memory in chunks of CHUNK (8.5 KiB, within the 16 KiB every Vulkan device
// offers). No subgroup operations, no float atomics: the sum order is fixed, so results are
// deterministic for a given input. icp_reduce_subgroup does the same on devices with subgroup
// arithmetic.
#define GROUP 128
#define CHUNK 17
layout(local_size_x = GROUP, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 0) const uint unused_x = 1;  // the runtime's workgroup specialization slots
layout(constant_id = 1) const uint unused_y = 1;
layout(std430, set = 0, binding = 0) readonly buffer Rows { vec4 rows[]; };
layout(std430, set = 0, binding = 1) readonly buffer CurVertices { vec4 cur_vertices[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Partials { float partials[]; };
layout(push_constant) uniform Push { IcpReduceParams p; };

#include "icp_reduce_rows.glsl"

shared float sums[CHUNK][GROUP];

void main() {
  uint t = gl_LocalInvocationID.x;
  uint g = gl_WorkGroupID.x;
  accumulate_rows(g, t, GROUP);
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
