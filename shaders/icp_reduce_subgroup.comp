#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "imufusion_layouts.h"

// icp_reduce on a device with subgroup arithmetic (the runtime checks): each subgroup adds its
// values with subgroupAdd, then one invocation per value adds the subgroups' sums in order; two
// barriers per chunk instead of one per halving. Any subgroup size up to GROUP works; the sum
// order is fixed for a given device, so results are deterministic there.
#define GROUP 128
#define CHUNK 17
#include "icp_reduce_rows.glsl"

void main() {
  uint t = gl_LocalInvocationID.x;
  uint g = gl_WorkGroupID.x;
  accumulate_rows(g, t, GROUP);
  for (int base = 0; base < ICP_REDUCE_VALUES; base += CHUNK) {
    int count = min(CHUNK, ICP_REDUCE_VALUES - base);
    for (int k = 0; k < count; ++k) {
      float total = subgroupAdd(acc[base + k]);
      if (subgroupElect()) sums[k][gl_SubgroupID] = total;
    }
    barrier();
    if (t < uint(count)) {
      float total = 0.0;
      for (uint s = 0u; s < gl_NumSubgroups; ++s) total += sums[t][s];
      partials[g * ICP_PARTIAL_STRIDE + uint(base) + t] = total;
    }
    barrier();  // the next chunk overwrites sums
  }
}
