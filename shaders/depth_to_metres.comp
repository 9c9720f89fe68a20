#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Raw { uint raw[]; };  // 2 x uint16 per word
layout(std430, set = 0, binding = 1) writeonly buffer Depth { float depth[]; };
layout(push_constant) uniform Push { DepthToMetresParams p; };

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = px.y * p.width + px.x;
  uint word = raw[i >> 1];
  uint value = (i & 1u) == 0u ? (word & 0xFFFFu) : (word >> 16);
  float d = float(value) * p.inv_depth_scale;
  depth[i] = (value != 0u && d >= p.min_depth && d <= p.max_depth) ? d : 0.0;
}
