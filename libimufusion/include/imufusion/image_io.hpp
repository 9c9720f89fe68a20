#pragma once
// Image files: 16-bit depth PNGs and 8-bit colour PNG / JPEG. Every error names the file.

#include <filesystem>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Reads a 16-bit single-channel PNG. Fails, naming the file, when it is missing, not a PNG,
/// truncated or corrupt, or not 16-bit grayscale (e.g. 8-bit: "wrong bit depth").
/// `depth_scale` (raw units per metre) is stored in the result.
Result<DepthImage> read_depth_png(const std::filesystem::path& path, double depth_scale);

/// Writes a 16-bit grayscale PNG, atomically (a temporary file renamed over `path`).
Status write_depth_png(const std::filesystem::path& path, const DepthImage& image);

/// Reads an 8-bit colour image (PNG or JPEG, chosen by content); grayscale is expanded to RGB.
Result<ColorImage> read_color_image(const std::filesystem::path& path);

/// Writes an 8-bit RGB PNG, atomically.
Status write_color_png(const std::filesystem::path& path, const ColorImage& image);

}  // namespace imufusion
