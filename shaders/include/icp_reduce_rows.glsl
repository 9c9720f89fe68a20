// The interface and first stage of icp_reduce and icp_reduce_subgroup (see IcpReduceParams); the
// including shader defines GROUP (invocations per workgroup) and CHUNK (values per shared-memory
// pass) first. accumulate_rows(g, t, stride) adds, in acc, rows g * rows_per_group + t, + stride,
// ... of the workgroup's range.
layout(local_size_x = GROUP, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 0) const uint unused_x = 1;  // the runtime's workgroup specialization slots
layout(constant_id = 1) const uint unused_y = 1;
layout(std430, set = 0, binding = 0) readonly buffer Rows { vec4 rows[]; };
layout(std430, set = 0, binding = 1) readonly buffer CurVertices { vec4 cur_vertices[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Partials { float partials[]; };
layout(push_constant) uniform Push { IcpReduceParams p; };

shared float sums[CHUNK][GROUP];

float acc[ICP_REDUCE_VALUES];

void accumulate_rows(uint g, uint t, uint stride) {
  for (int k = 0; k < ICP_REDUCE_VALUES; ++k) acc[k] = 0.0;
  uint begin = g * p.rows_per_group;
  uint end = min(begin + p.rows_per_group, p.row_count);
  for (uint r = begin + t; r < end; r += stride) {
    vec4 r0 = rows[2u * r];
    vec4 r1 = rows[2u * r + 1u];
    float w = r1.w;
    if (w == 0.0) continue;
    float information = 1.0;
    if (p.noise_a > 0.0) {
      float dz = cur_vertices[r].z - p.noise_z0;
      float ratio = p.noise_a / (p.noise_a + p.noise_b * dz * dz);
      information = ratio * ratio;
    }
    acc[30] += information;
    acc[32] += 1.0;
    if (w == -2.0) {
      acc[33] += information;
      acc[34] += 1.0;
    }
    if (w < 0.0) continue;
    acc[31] += information;
    // The upper triangle of w a a^T row by row, then w a b, written out: a loop over an index
    // array is slower on CPU devices.
    float a0 = r0.x, a1 = r0.y, a2 = r0.z, a3 = r0.w, a4 = r1.x, a5 = r1.y, b = r1.z;
    float w0 = w * a0, w1 = w * a1, w2 = w * a2, w3 = w * a3, w4 = w * a4, w5 = w * a5;
    acc[0] += w0 * a0;
    acc[1] += w0 * a1;
    acc[2] += w0 * a2;
    acc[3] += w0 * a3;
    acc[4] += w0 * a4;
    acc[5] += w0 * a5;
    acc[6] += w1 * a1;
    acc[7] += w1 * a2;
    acc[8] += w1 * a3;
    acc[9] += w1 * a4;
    acc[10] += w1 * a5;
    acc[11] += w2 * a2;
    acc[12] += w2 * a3;
    acc[13] += w2 * a4;
    acc[14] += w2 * a5;
    acc[15] += w3 * a3;
    acc[16] += w3 * a4;
    acc[17] += w3 * a5;
    acc[18] += w4 * a4;
    acc[19] += w4 * a5;
    acc[20] += w5 * a5;
    acc[21] += w0 * b;
    acc[22] += w1 * b;
    acc[23] += w2 * b;
    acc[24] += w3 * b;
    acc[25] += w4 * b;
    acc[26] += w5 * b;
    acc[27] += w * b * b;
    acc[28] += 1.0;
    acc[29] += w;
  }
}
