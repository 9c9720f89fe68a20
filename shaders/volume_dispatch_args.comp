#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

// The workgroup counts of the integration and range passes from the volume's counters (see
// VolumeArgsParams), so that they follow the allocation in one submission.
layout(local_size_x = 1, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 0) const uint unused_x = 1;  // the runtime's workgroup specialization slots
layout(constant_id = 1) const uint unused_y = 1;
layout(std430, set = 0, binding = 0) readonly buffer Counters { uint counters[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Args { uint args[]; };
layout(push_constant) uniform Push { VolumeArgsParams p; };

void main() {
  uint listed = counters[VOLUME_COUNTER_VISIBLE];
  uint x = min(listed, uint(VOLUME_INTEGRATE_GROUPS_X));
  args[VOLUME_ARGS_INTEGRATE] = x;
  args[VOLUME_ARGS_INTEGRATE + 1] = x == 0u ? 0u : (listed + x - 1u) / x;
  args[VOLUME_ARGS_INTEGRATE + 2] = 1u;
  uint blocks = min(counters[VOLUME_COUNTER_ALLOCATED], p.pool_blocks);
  args[VOLUME_ARGS_RANGE] = (blocks + uint(VOLUME_RANGE_GROUP) - 1u) / uint(VOLUME_RANGE_GROUP);
  args[VOLUME_ARGS_RANGE + 1] = 1u;
  args[VOLUME_ARGS_RANGE + 2] = 1u;
}
