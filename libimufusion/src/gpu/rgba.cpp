#include "gpu/rgba.hpp"

namespace imufusion::gpu {

namespace {

// Row by row, following the view's stride.
void pack(const ColorView& image, std::uint32_t* out) {
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u) *out++ = image.rgba(u, v);
}

}  // namespace

void pack_rgba(const ColorView& image, std::vector<std::uint32_t>& out) {
  out.resize(static_cast<std::size_t>(image.width) * image.height);
  pack(image, out.data());
}

Status upload_rgba(const ColorView& image, Buffer& buffer, std::vector<std::uint32_t>& scratch) {
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  if (buffer.mapped() != nullptr && buffer.size() >= pixels * 4) {
    pack(image, static_cast<std::uint32_t*>(buffer.mapped()));
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
