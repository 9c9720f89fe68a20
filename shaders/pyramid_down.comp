#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Src { float src[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Dst { float dst[]; };
layout(push_constant) uniform Push { PyramidDownParams p; };

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.dst_width || px.y >= p.dst_height) return;
  float d[4];
  float nearest = 1e30;
  for (uint k = 0u; k < 4u; ++k) {
    uint x = 2u * px.x + (k & 1u);
    uint y = 2u * px.y + (k >> 1);
    d[k] = src[y * p.src_width + x];
    if (d[k] > 0.0) nearest = min(nearest, d[k]);
  }
  float sum = 0.0;
  float count = 0.0;
  for (uint k = 0u; k < 4u; ++k) {
    if (d[k] > 0.0 && d[k] - nearest <= p.max_jump_fraction * nearest) {
      sum += d[k];
      count += 1.0;
    }
  }
  dst[px.y * p.dst_width + px.x] = count > 0.0 ? sum / count : 0.0;
}
