#pragma once
// Plain CPU implementations of the preprocessing kernels, written from their definitions (see
// shaders/include/imufusion_layouts.h) in double precision: the oracle for the GPU tests.

#include "imufusion/preprocess.hpp"
#include "imufusion/types.hpp"

namespace imufusion::reference {

FloatImage depth_to_metres(const DepthImage& raw, double min_depth, double max_depth);
FloatImage bilateral(const FloatImage& depth, int radius, double sigma_space, double sigma_depth);
FloatImage pyramid_down(const FloatImage& depth, double max_jump_fraction);
Vec4Image vertex_map(const FloatImage& depth, const Intrinsics& level_intrinsics);
Vec4Image normal_map(const Vec4Image& vertices, double max_jump_fraction);

/// The whole chain, as gpu::Preprocessor::record computes it with `first_map_level` (0: as
/// DepthPreprocessor::process does); maps from that level on, the levels before it empty (timings
/// left empty).
PreprocessedFrame preprocess(const DepthImage& raw, const Intrinsics& intrinsics,
                             const PreprocessConfig& config, int first_map_level = 0);

}  // namespace imufusion::reference
