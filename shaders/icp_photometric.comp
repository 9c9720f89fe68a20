#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer CurVertices { vec4 cur_vertices[]; };
layout(std430, set = 0, binding = 1) readonly buffer CurColors { uint cur_colors[]; };  // RGBA8
layout(std430, set = 0, binding = 2) readonly buffer RefVertices { vec4 ref_vertices[]; };
layout(std430, set = 0, binding = 3) readonly buffer RefColors { uint ref_colors[]; };  // RGBA8
// icp_associate's row format: (a0..a3), (a4, a5, b, w); w = 0: no vertex, w = -1: rejected.
layout(std430, set = 0, binding = 4) writeonly buffer Rows { vec4 rows[]; };
// The depth's association rows of the same pose (icp_associate, one per level pixel).
layout(std430, set = 0, binding = 5) readonly buffer DepthRows { vec4 depth_rows[]; };
layout(push_constant) uniform Push { IcpPhotometricParams p; };

const vec3 kLuma = vec3(0.299, 0.587, 0.114);

void reject(uint i, float marker) {
  rows[2u * i] = vec4(0.0);
  rows[2u * i + 1u] = vec4(0.0, 0.0, 0.0, marker);
}

void main() {
  // One row per sampled pixel: every p.step-th of the level in x and y.
  uvec2 sample_px = gl_GlobalInvocationID.xy;
  uint samples_x = (p.width + p.step - 1u) / p.step;
  uvec2 px = sample_px * p.step;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = sample_px.y * samples_x + sample_px.x;
  uint pixel = px.y * p.width + px.x;
  vec4 v = cur_vertices[pixel];
  if (v.w <= 0.0) {
    reject(i, 0.0);
    return;
  }
  // Only where the depth pairs the pixel with the model: not across an occlusion, a depth edge
  // or a flying pixel, whose colour belongs to another surface.
  if (depth_rows[2u * pixel + 1u].w <= 0.0) {
    reject(i, -1.0);
    return;
  }
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);  // column-major
  vec3 pt = R * v.xyz + vec3(p.tx, p.ty, p.tz);
  if (pt.z <= 0.0) {
    reject(i, -1.0);
    return;
  }
  float u = p.fx * pt.x / pt.z + p.cx;
  float w = p.fy * pt.y / pt.z + p.cy;
  // The 2x2 bilinear cell and one pixel around it for the central differences.
  int x0 = int(floor(u)), y0 = int(floor(w));
  if (x0 < 1 || y0 < 1 || x0 + 2 >= int(p.ref_width) || y0 + 2 >= int(p.ref_height)) {
    reject(i, -1.0);
    return;
  }
  // The 4x4 block around the cell without its corners: the cell's pixels and their
  // 4-neighbours, each with a surface point within max_distance of p in depth.
  float nearby[4][4];
  for (int dy = 0; dy < 4; ++dy) {
    for (int dx = 0; dx < 4; ++dx) {
      if ((dx == 0 || dx == 3) && (dy == 0 || dy == 3)) continue;
      uint j = uint(y0 - 1 + dy) * p.ref_width + uint(x0 - 1 + dx);
      vec4 q = ref_vertices[j];
      if (q.w <= 0.0 || abs(q.z - pt.z) > p.max_distance) {
        reject(i, -1.0);
        return;
      }
      nearby[dy][dx] = dot(unpackUnorm4x8(ref_colors[j]).rgb, kLuma);
    }
  }
  // The intensity and its central-difference gradient at the cell's corners, interpolated.
  float fu = u - float(x0), fw = w - float(y0);
  float value = 0.0;
  vec2 gradient = vec2(0.0);
  for (int c = 0; c < 4; ++c) {
    int x = 1 + (c & 1), y = 1 + (c >> 1);
    float s = ((c & 1) == 1 ? fu : 1.0 - fu) * ((c >> 1) == 1 ? fw : 1.0 - fw);
    value += s * nearby[y][x];
    gradient += s * 0.5 * vec2(nearby[y][x + 1] - nearby[y][x - 1], nearby[y + 1][x] - nearby[y - 1][x]);
  }
  // The current intensity: the mean over the colour pixels this level pixel covers.
  uint side = 1u << p.color_shift;
  float current = 0.0;
  for (uint dy = 0u; dy < side; ++dy)
    for (uint dx = 0u; dx < side; ++dx)
      current += dot(
          unpackUnorm4x8(cur_colors[(px.y * side + dy) * p.color_width + px.x * side + dx]).rgb,
          kLuma);
  current /= float(side * side);
  float inv_z = 1.0 / pt.z;
  vec3 g = vec3(gradient.x * p.fx * inv_z, gradient.y * p.fy * inv_z,
                -(gradient.x * p.fx * pt.x + gradient.y * p.fy * pt.y) * inv_z * inv_z);
  float b = current - value;
  float weight = abs(b) <= p.huber ? 1.0 : p.huber / abs(b);
  rows[2u * i] = vec4(cross(pt, g), g.x);
  rows[2u * i + 1u] = vec4(g.y, g.z, b, weight);
}
