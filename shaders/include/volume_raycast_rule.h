// The marching rule of volume_raycast, shared by the shader and its CPU reference
// (reference/volume_reference.cpp); valid as GLSL and C++.
//
// Along the ray, at the sample point w (world metres):
//   - the block holding w is unallocated: step to where the ray leaves it, plus
//     VOLUME_RAYCAST_EXIT_MARGIN voxels (past float rounding at the face);
//   - the voxel nearest to w (one read) is unobserved: step one voxel (a surface is found only
//     between two trilinear samples in observed space, which reaches a truncation in front of
//     it);
//   - its TSDF is at least VOLUME_RAYCAST_COARSE_VOXELS voxels (tsdf * truncation): step
//     0.8 * tsdf * truncation - 1 voxel. w lies within sqrt(3)/2 voxel of that lattice point, so
//     where the TSDF's slope along the ray is at most 1 the step ends in front of the surface;
//   - otherwise the trilinear TSDF at w (all 8 corners observed, else step half a voxel): a
//     + to - change from the previous trilinear sample is the hit, refined linearly; else step
//     0.8 * tsdf * truncation, at least half a voxel.
// Any step but the last kind forgets the previous trilinear sample. Leaving unallocated blocks
// through their faces makes the samples in allocated blocks independent of where the march
// starts. At the hit, the normal is the central difference of the trilinear TSDF one voxel
// apart along each axis, the colour the trilinear colour; an unobserved corner is a miss.
#ifndef VOLUME_RAYCAST_RULE_H
#define VOLUME_RAYCAST_RULE_H

#define VOLUME_RAYCAST_COARSE_VOXELS 2.0
#define VOLUME_RAYCAST_EXIT_MARGIN 0.01

#endif
