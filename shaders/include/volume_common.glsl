// Block keys, hashing and lookup of the sparse TSDF volume. The including shader declares the
// buffers `keys[]` and `values[]` (the hash table) before including this file.

const int kKeyMinXY = -1024;
const int kKeyMaxXY = 1023;
const int kKeyMinZ = -512;
const int kKeyMaxZ = 511;

// (kKeyMaxXY, kKeyMaxXY, kKeyMaxZ) would pack to VOLUME_EMPTY_KEY: it counts as out of range.
bool key_in_range(ivec3 b) {
  return b.x >= kKeyMinXY && b.x <= kKeyMaxXY && b.y >= kKeyMinXY && b.y <= kKeyMaxXY &&
         b.z >= kKeyMinZ && b.z <= kKeyMaxZ && b != ivec3(kKeyMaxXY, kKeyMaxXY, kKeyMaxZ);
}

uint pack_key(ivec3 b) {
  return uint(b.x - kKeyMinXY) | (uint(b.y - kKeyMinXY) << 11) | (uint(b.z - kKeyMinZ) << 22);
}

ivec3 unpack_key(uint key) {
  return ivec3(int(key & 0x7FFu) + kKeyMinXY, int((key >> 11) & 0x7FFu) + kKeyMinXY,
               int(key >> 22) + kKeyMinZ);
}

uint hash_block(ivec3 b, uint mask) {
  return ((uint(b.x) * 73856093u) ^ (uint(b.y) * 19349669u) ^ (uint(b.z) * 83492791u)) & mask;
}

// The pool index of block b, or VOLUME_NO_BLOCK when it is not allocated.
uint find_block(ivec3 b, uint mask) {
  if (!key_in_range(b)) return VOLUME_NO_BLOCK;
  uint key = pack_key(b);
  uint slot = hash_block(b, mask);
  for (int probe = 0; probe < VOLUME_MAX_PROBES; ++probe) {
    uint k = keys[slot];
    if (k == key) return values[slot];
    if (k == VOLUME_EMPTY_KEY) return VOLUME_NO_BLOCK;
    slot = (slot + 1u) & mask;
  }
  return VOLUME_NO_BLOCK;
}

float unpack_tsdf(uint word0) {
  int raw = int(word0 << 16) >> 16;  // sign-extend the low 16 bits
  return float(raw) / 32767.0;
}

uint unpack_weight(uint word0) { return word0 >> 16; }

uint pack_voxel_word0(float tsdf, uint weight) {
  int raw = clamp(int(round(tsdf * 32767.0)), -32767, 32767);
  return (uint(raw) & 0xFFFFu) | (weight << 16);
}
