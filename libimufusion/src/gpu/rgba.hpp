#pragma once
// RGB8 images <-> RGBA8 words, the colour layout of the GPU buffers (R in the low byte).

#include <cstdint>
#include <vector>

#include "imufusion/types.hpp"

namespace imufusion::gpu {

/// Packs an RGB8 image into `out` (resized), alpha 255.
void pack_rgba(const ColorImage& image, std::vector<std::uint32_t>& out);
/// Unpacks RGBA8 words into an RGB8 image of the given size.
ColorImage unpack_rgba(const std::vector<std::uint32_t>& rgba, int width, int height);

}  // namespace imufusion::gpu
