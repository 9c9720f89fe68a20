#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// Half-resolution vertex and normal maps from full-resolution ones (a model raycast), by the
// depth pyramid's rule (pyramid_down.comp): each output pixel averages the valid entries
// (w > 0 in both maps) of its 2x2 block whose depth lies within max_jump_fraction of the block's
// nearest depth; the normal sum is renormalized. CPU reference: core/map_pyramid.cpp.
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer SrcVertices { vec4 src_vertices[]; };
layout(std430, set = 0, binding = 1) readonly buffer SrcNormals { vec4 src_normals[]; };
layout(std430, set = 0, binding = 2) writeonly buffer DstVertices { vec4 dst_vertices[]; };
layout(std430, set = 0, binding = 3) writeonly buffer DstNormals { vec4 dst_normals[]; };
layout(push_constant) uniform Push { PyramidDownParams p; };

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.dst_width || px.y >= p.dst_height) return;
  uint out_index = px.y * p.dst_width + px.x;
  vec4 v[4];
  vec4 n[4];
  bool valid[4];
  float nearest = 0.0;
  for (uint k = 0u; k < 4u; ++k) {
    uint i = (2u * px.y + (k >> 1)) * p.src_width + 2u * px.x + (k & 1u);
    v[k] = src_vertices[i];
    n[k] = src_normals[i];
    valid[k] = v[k].w > 0.0 && n[k].w > 0.0;
    if (valid[k] && (nearest == 0.0 || v[k].z < nearest)) nearest = v[k].z;
  }
  vec4 point = vec4(0.0);
  vec4 normal = vec4(0.0);
  if (nearest > 0.0) {
    for (uint k = 0u; k < 4u; ++k) {
      if (valid[k] && v[k].z - nearest <= p.max_jump_fraction * nearest) {
        point += v[k];
        normal += n[k];
      }
    }
  }
  float len = length(normal.xyz);
  if (nearest <= 0.0 || len <= 0.0) {
    dst_vertices[out_index] = vec4(0.0);
    dst_normals[out_index] = vec4(0.0);
    return;
  }
  dst_vertices[out_index] = point / point.w;
  dst_normals[out_index] = vec4(normal.xyz / len, 1.0);
}
