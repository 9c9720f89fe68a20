#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// Gives the blocks a frame was refused, now that the pool holds them, their pool index (see
// VolumePoolGrowParams).
layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) buffer Values { uint values[]; };
layout(std430, set = 0, binding = 1) readonly buffer BlockSlots { uint block_slots[]; };
layout(push_constant) uniform Push { VolumePoolGrowParams p; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= p.count) return;
  values[block_slots[p.first + i]] = p.first + i;
}
