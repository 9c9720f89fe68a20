#pragma once
// RGB8 images <-> RGBA8 words, the colour layout of the GPU buffers (R in the low byte).

#include <cstdint>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"
#include "vk/buffer.hpp"

namespace imufusion::gpu {

/// Packs a colour view (any ColorFormat, any stride) into `out` (resized), alpha 255.
void pack_rgba(const ColorView& image, std::vector<std::uint32_t>& out);
/// Packs a colour view into `buffer` as RGBA8 words: straight into its memory when it is
/// host-visible, else through `scratch`. With `sources` (undistortion_sources, one per pixel)
/// pixel i takes the view's pixel sources[i], black where it is -1.
Status upload_rgba(const ColorView& image, Buffer& buffer, std::vector<std::uint32_t>& scratch,
                   const std::vector<std::int32_t>* sources = nullptr);
/// Unpacks RGBA8 words into an RGB8 image of the given size.
ColorImage unpack_rgba(const std::vector<std::uint32_t>& rgba, int width, int height);

}  // namespace imufusion::gpu
