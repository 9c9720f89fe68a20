#pragma once
// Resampling of distorted frames to the pinhole of their intrinsics (Intrinsics::distortion).
#include <cstdint>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Where each pixel of the pinhole image (row-major, k.width x k.height) takes its value from: the
/// index of the distorted frame's pixel nearest to where the lens puts that pixel's ray, or -1
/// where that falls outside the frame. Empty for an undistorted camera. Fails naming a
/// coefficient that is not finite.
Result<std::vector<std::int32_t>> undistortion_sources(const Intrinsics& k);

/// The point where the lens puts normalized pinhole coordinates (x, y) (OpenCV's model).
void distort_normalized(const Intrinsics& k, double x, double y, double* xd, double* yd);

}  // namespace imufusion
