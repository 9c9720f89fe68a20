#pragma once
// libpng's classic API behind functions that return errors as values. libpng reports errors by
// longjmp; every setjmp lives in a small function whose frame holds no C++ object with a
// destructor, so a longjmp never skips one (see png_codec.cpp).

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion::io {

/// The IHDR fields of a PNG, read without decoding the image.
struct PngHeader {
  int width = 0, height = 0;
  int bit_depth = 0;   // bits per channel
  int color_type = 0;  // PNG_COLOR_TYPE_*
};

/// True when `bytes` start with the 8-byte PNG signature.
bool has_png_signature(const std::vector<std::uint8_t>& bytes);

/// Reads only the first 33 bytes of `path` (signature and IHDR): cheap enough to run on every
/// frame of a sequence at open.
Result<PngHeader> read_png_header(const std::filesystem::path& path);

/// Decodes a 16-bit grayscale PNG held in memory; `path` is only used in messages.
Result<DepthImage> decode_depth_png(const std::vector<std::uint8_t>& bytes,
                                    const std::filesystem::path& path, double depth_scale);

/// Decodes an 8-bit (or 16-bit, reduced to 8) gray, gray+alpha, palette, RGB or RGBA PNG into RGB.
Result<ColorImage> decode_color_png(const std::vector<std::uint8_t>& bytes,
                                    const std::filesystem::path& path);

/// Encodes 16-bit gray (`channels` 1, `pixels` holds uint16 in host order) or 8-bit RGB
/// (`channels` 3) rows into `file`.
Status encode_png(std::FILE* file, const std::filesystem::path& path, int width, int height,
                  int channels, const void* pixels);

}  // namespace imufusion::io
