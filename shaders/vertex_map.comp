#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Depth { float depth[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Vertices { vec4 vertices[]; };
layout(push_constant) uniform Push { VertexMapParams p; };

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = px.y * p.width + px.x;
  float d = depth[i];
  if (d <= 0.0) {
    vertices[i] = vec4(0.0);
    return;
  }
  vertices[i] = vec4((float(px.x) - p.cx) * d / p.fx, (float(px.y) - p.cy) * d / p.fy, d, 1.0);
}
