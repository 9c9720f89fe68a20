#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Src { float src[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Dst { float dst[]; };
layout(push_constant) uniform Push { BilateralParams p; };

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(p.width, p.height);
  if (px.x >= size.x || px.y >= size.y) return;
  float dc = src[px.y * size.x + px.x];
  if (dc <= 0.0) {
    dst[px.y * size.x + px.x] = 0.0;
    return;
  }
  float sum = 0.0;
  float weight = 0.0;
  for (int dy = -p.radius; dy <= p.radius; ++dy) {
    int y = px.y + dy;
    if (y < 0 || y >= size.y) continue;
    for (int dx = -p.radius; dx <= p.radius; ++dx) {
      int x = px.x + dx;
      if (x < 0 || x >= size.x) continue;
      float d = src[y * size.x + x];
      if (d <= 0.0) continue;
      float dd = d - dc;
      float w = exp(-float(dx * dx + dy * dy) * p.inv_two_sigma_space_sq -
                    dd * dd * p.inv_two_sigma_depth_sq);
      sum += w * d;
      weight += w;
    }
  }
  dst[px.y * size.x + px.x] = sum / weight;  // weight >= 1: the centre always contributes
}
