#version 450
#extension GL_GOOGLE_include_directive : require
#include "imufusion_layouts.h"

layout(local_size_x_id = 0, local_size_y_id = 1, local_size_z = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Depth { float depth[]; };  // metres
layout(std430, set = 0, binding = 1) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 2) buffer Values { uint values[]; };
layout(std430, set = 0, binding = 3) buffer Stamps { uint stamps[]; };
layout(std430, set = 0, binding = 4) buffer Visible { uint visible[]; };  // hash slots
layout(std430, set = 0, binding = 5) buffer Counters { uint counters[]; };
layout(std430, set = 0, binding = 6) buffer BlockSlots { uint block_slots[]; };  // pool -> slot
layout(push_constant) uniform Push { VolumeAllocateParams p; };

#include "volume_common.glsl"

// Lists the slot once this frame. Neighbouring pixels touch the same blocks: the plain read ends
// most repeats without an atomic (a stale read only falls through to the exchange).
void mark_visible(uint slot) {
  if (stamps[slot] == p.frame_stamp) return;
  if (atomicExchange(stamps[slot], p.frame_stamp) == p.frame_stamp) return;
  visible[atomicAdd(counters[VOLUME_COUNTER_VISIBLE], 1u)] = slot;  // < hash_slots entries
}

// The hash slot holding block b, inserted if new; VOLUME_EMPTY_KEY when the table had no free
// slot within the probes. The block is then listed once (mark_visible) by the caller.
uint insert(ivec3 b) {
  uint key = pack_key(b);
  uint slot = hash_block(b, p.hash_mask);
  for (int probe = 0; probe < VOLUME_MAX_PROBES; ++probe) {
    // A key, once written, never changes: a plain read that sees one is final; one that sees
    // an empty slot is checked by the compare-and-swap.
    uint k = keys[slot];
    if (k == VOLUME_EMPTY_KEY) {
      k = atomicCompSwap(keys[slot], VOLUME_EMPTY_KEY, key);
      if (k == VOLUME_EMPTY_KEY) {
        uint index = atomicAdd(counters[VOLUME_COUNTER_ALLOCATED], 1u);
        values[slot] = index < p.pool_blocks ? index : VOLUME_NO_BLOCK;
        if (index < p.max_blocks) block_slots[index] = slot;
        return slot;
      }
    }
    if (k == key) return slot;
    slot = (slot + 1u) & p.hash_mask;
  }
  return VOLUME_EMPTY_KEY;
}

// The blocks the pixel's truncation band [d - truncation, d + truncation] passes are those of
// its samples every half block along it. Consecutive samples mostly share a block: the samples
// are walked to the next block not yet inserted before each insertion, so that an invocation
// runs the insertion once per distinct block (the loop's trip count bounds a SIMD group's work).
void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= p.width || px.y >= p.height) return;
  float d = depth[px.y * p.width + px.x];
  if (d <= 0.0) return;
  vec3 ray = vec3((float(px.x) - p.cx) / p.fx, (float(px.y) - p.cy) / p.fy, 1.0);
  mat3 R = mat3(p.r00, p.r10, p.r20, p.r01, p.r11, p.r21, p.r02, p.r12, p.r22);
  vec3 t = vec3(p.tx, p.ty, p.tz);
  vec3 a = R * (ray * max(d - p.truncation, 0.0)) + t;
  vec3 c = R * (ray * (d + p.truncation)) + t;
  float block_length = p.voxel_size * float(VOLUME_BLOCK_SIDE);
  int steps = int(ceil(distance(a, c) / (0.5 * block_length)));
  ivec3 last = ivec3(0x7FFFFFFF);
  uint out_of_range = 0u, table_full = 0u;
  int i = 0;
  while (i <= steps) {
    ivec3 b = ivec3(floor(mix(a, c, float(i) / float(max(steps, 1))) / block_length));
    ++i;
    while (b == last && i <= steps) {
      b = ivec3(floor(mix(a, c, float(i) / float(max(steps, 1))) / block_length));
      ++i;
    }
    if (b == last) break;
    last = b;
    if (!key_in_range(b)) {
      ++out_of_range;
      continue;
    }
    uint slot = insert(b);
    if (slot == VOLUME_EMPTY_KEY) {
      ++table_full;
      continue;
    }
    mark_visible(slot);
  }
  if (out_of_range > 0u) atomicAdd(counters[VOLUME_COUNTER_OUT_OF_RANGE], out_of_range);
  if (table_full > 0u) atomicAdd(counters[VOLUME_COUNTER_TABLE_FULL], table_full);
}
