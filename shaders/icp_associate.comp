#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer CurVertices { vec4 cur_vertices[]; };
layout(std430, set = 0, binding = 1) readonly buffer CurNormals { vec4 cur_normals[]; };
layout(std430, set = 0, binding = 2) readonly buffer RefVertices { vec4 ref_vertices[]; };
layout(std430, set = 0, binding = 3) readonly buffer RefNormals { vec4 ref_normals[]; };
// Two vec4 per current pixel: (a0..a3), (a4, a5, b, w); w = 0: no vertex or normal here,
// w = -1: a valid pixel whose pair was rejected, w = -2: a valid pixel the reference does not
// cover (its projection falls behind the camera, outside the image or on a pixel without a
// vertex or normal).
layout(std430, set = 0, binding = 4) writeonly buffer Rows { vec4 rows[]; };
layout(push_constant) uniform Push { IcpAssociateParams p; };

void reject(uint i, float marker) {
  rows[2u * i] = vec4(0.0);
  rows[2u * i + 1u] = vec4(0.0, 0.0, 0.0, marker);
}

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  uint i = px.y * p.width + px.x;
  vec4 v = cur_vertices[i];
  vec4 n = cur_normals[i];
  if (v.w <= 0.0 || n.w <= 0.0) {
    reject(i, 0.0);
    return;
  }
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);  // column-major
  vec3 pt = R * v.xyz + vec3(p.tx, p.ty, p.tz);
  vec3 m = R * n.xyz;
  if (pt.z <= 0.0) {
    reject(i, -2.0);
    return;
  }
  // Nearest reference pixel to the projection (pixel centres at integer coordinates).
  float u = floor(p.fx * pt.x / pt.z + p.cx + 0.5);
  float w = floor(p.fy * pt.y / pt.z + p.cy + 0.5);
  if (u < 0.0 || w < 0.0 || u >= float(p.ref_width) || w >= float(p.ref_height)) {
    reject(i, -2.0);
    return;
  }
  uint j = uint(w) * p.ref_width + uint(u);
  vec4 q = ref_vertices[j];
  vec4 g = ref_normals[j];
  if (q.w <= 0.0 || g.w <= 0.0) {
    reject(i, -2.0);
    return;
  }
  float dist = distance(pt, q.xyz);
  float cosine = dot(m, g.xyz);
  float sigma = p.noise_a + p.noise_b * (v.z - p.noise_z0) * (v.z - p.noise_z0);
  float tan_noise = p.noise_k * sigma * p.fx / v.z;
  float min_cos = min(p.min_normal_cos, max(inversesqrt(1.0 + tan_noise * tan_noise), p.max_noise_cos));
  if (dist > p.max_distance || cosine < min_cos) {
    reject(i, -1.0);
    return;
  }
  float weight = cosine * (1.0 - dist / p.max_distance);
  vec3 a_rot = cross(pt, g.xyz);
  float b = dot(g.xyz, q.xyz - pt);
  rows[2u * i] = vec4(a_rot, g.x);
  rows[2u * i + 1u] = vec4(g.y, g.z, b, weight);
}
