#include "gpu/rgba.hpp"

namespace imufusion::gpu {

void pack_rgba(const ColorImage& image, std::vector<std::uint32_t>& out) {
  out.resize(static_cast<std::size_t>(image.width) * image.height);
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = std::uint32_t{image.data[3 * i]} | (std::uint32_t{image.data[3 * i + 1]} << 8) |
             (std::uint32_t{image.data[3 * i + 2]} << 16) | 0xFF000000u;
  }
}

ColorImage unpack_rgba(const std::vector<std::uint32_t>& rgba, int width, int height) {
  ColorImage image;
  image.width = width;
  image.height = height;
  image.data.resize(rgba.size() * 3);
  for (std::size_t i = 0; i < rgba.size(); ++i) {
    image.data[3 * i] = static_cast<std::uint8_t>(rgba[i] & 0xFF);
    image.data[3 * i + 1] = static_cast<std::uint8_t>((rgba[i] >> 8) & 0xFF);
    image.data[3 * i + 2] = static_cast<std::uint8_t>((rgba[i] >> 16) & 0xFF);
  }
  return image;
}

}  // namespace imufusion::gpu
