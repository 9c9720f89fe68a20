#include "gpu/rgba.hpp"

namespace imufusion::gpu {

namespace {

void pack(const ColorImage& image, std::uint32_t* out, std::size_t pixels) {
  for (std::size_t i = 0; i < pixels; ++i) {
    out[i] = std::uint32_t{image.data[3 * i]} | (std::uint32_t{image.data[3 * i + 1]} << 8) |
             (std::uint32_t{image.data[3 * i + 2]} << 16) | 0xFF000000u;
  }
}

}  // namespace

void pack_rgba(const ColorImage& image, std::vector<std::uint32_t>& out) {
  out.resize(static_cast<std::size_t>(image.width) * image.height);
  pack(image, out.data(), out.size());
}

Status upload_rgba(const ColorImage& image, Buffer& buffer, std::vector<std::uint32_t>& scratch) {
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  if (buffer.mapped() != nullptr && buffer.size() >= pixels * 4) {
    pack(image, static_cast<std::uint32_t*>(buffer.mapped()), pixels);
    return {};
  }
  pack_rgba(image, scratch);
  return buffer.upload(scratch.data(), scratch.size() * 4);
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
