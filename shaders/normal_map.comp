#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Normals { vec4 normals[]; };
layout(push_constant) uniform Push { NormalMapParams p; };

bool usable(vec4 v, float centre_depth) {
  return v.w > 0.0 && abs(v.z - centre_depth) <= p.max_jump_fraction * centre_depth;
}

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = ivec2(p.width, p.height);
  if (px.x >= size.x || px.y >= size.y) return;
  int i = px.y * size.x + px.x;
  vec4 c = vertices[i];
  if (c.w <= 0.0 || px.x == 0 || px.y == 0 || px.x == size.x - 1 || px.y == size.y - 1) {
    normals[i] = vec4(0.0);
    return;
  }
  vec4 l = vertices[i - 1];
  vec4 r = vertices[i + 1];
  vec4 u = vertices[i - size.x];
  vec4 d = vertices[i + size.x];
  if (!usable(l, c.z) || !usable(r, c.z) || !usable(u, c.z) || !usable(d, c.z)) {
    normals[i] = vec4(0.0);
    return;
  }
  vec3 n = cross(r.xyz - l.xyz, d.xyz - u.xyz);
  float len = length(n);
  if (len <= 0.0) {
    normals[i] = vec4(0.0);
    return;
  }
  n /= len;
  if (dot(n, c.xyz) > 0.0) n = -n;  // face the camera
  normals[i] = vec4(n, 1.0);
}
