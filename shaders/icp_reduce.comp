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
#include "icp_reduce_rows.glsl"

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
