#include "imufusion/image_io.hpp"

#include <cmath>
#include <string>

#include "io/atomic_file.hpp"
#include "io/png_codec.hpp"

// stb_image decodes the JPEG colour frames of TUM recordings; PNG goes through libpng (16-bit
// depth support and error handling as values). Files are read into memory first, so stb's stdio
// layer is not needed.
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#define STBI_NO_HDR
#include <stb_image.h>

namespace imufusion {
namespace {

bool has_jpeg_signature(const std::vector<std::uint8_t>& bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
}

Result<ColorImage> decode_jpeg(const std::vector<std::uint8_t>& bytes,
                               const std::filesystem::path& path) {
  if (bytes.size() > static_cast<std::size_t>(INT32_MAX)) {
    return make_error(ErrorCode::kUnsupported, path.string() + ": JPEG file too large");
  }
  int width = 0, height = 0, channels_in_file = 0;
  stbi_uc* pixels = stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &width,
                                          &height, &channels_in_file, 3);
  if (pixels == nullptr) {
    const char* reason = stbi_failure_reason();
    return make_error(ErrorCode::kParseError, path.string() + ": corrupt or unsupported JPEG (" +
                                                  (reason != nullptr ? reason : "unknown") + ")");
  }
  ColorImage image;
  image.width = width;
  image.height = height;
  image.data.assign(pixels, pixels + static_cast<std::size_t>(width) * height * 3);
  stbi_image_free(pixels);
  return image;
}

}  // namespace

Result<DepthImage> read_depth_png(const std::filesystem::path& path, double depth_scale) {
  if (!std::isfinite(depth_scale) || depth_scale <= 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      path.string() + ": depth_scale " + std::to_string(depth_scale) +
                          " must be a positive number of raw units per metre");
  }
  auto bytes = io::read_file_bytes(path);
  if (!bytes.ok()) return bytes.error();
  return io::decode_depth_png(*bytes, path, depth_scale);
}

Status write_depth_png(const std::filesystem::path& path, const DepthImage& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.data.size() != static_cast<std::size_t>(image.width) * image.height) {
    return make_error(ErrorCode::kInvalidArgument,
                      path.string() + ": depth image " + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + " holds " +
                          std::to_string(image.data.size()) + " values");
  }
  return io::write_file_atomically(path, [&](std::FILE* file) {
    return io::encode_png(file, path, image.width, image.height, 1, image.data.data());
  });
}

Result<ColorImage> read_color_image(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes.ok()) return bytes.error();
  if (io::has_png_signature(*bytes)) return io::decode_color_png(*bytes, path);
  if (has_jpeg_signature(*bytes)) return decode_jpeg(*bytes, path);
  return make_error(ErrorCode::kParseError, path.string() + ": neither a PNG nor a JPEG file");
}

Status write_color_png(const std::filesystem::path& path, const ColorImage& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.data.size() != static_cast<std::size_t>(image.width) * image.height * 3) {
    return make_error(ErrorCode::kInvalidArgument,
                      path.string() + ": colour image " + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + " holds " +
                          std::to_string(image.data.size()) + " bytes, expected 3 per pixel");
  }
  return io::write_file_atomically(path, [&](std::FILE* file) {
    return io::encode_png(file, path, image.width, image.height, 3, image.data.data());
  });
}

}  // namespace imufusion
