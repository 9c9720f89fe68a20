#include "gpu/rgba.hpp"

#include <string>

namespace imufusion::gpu {

namespace {

// Row by row, following the view's stride; through `sources` when given.
void pack(const ColorView& image, std::uint32_t* out,
          const std::vector<std::int32_t>* sources = nullptr) {
  if (sources != nullptr && !sources->empty()) {
    for (const std::int32_t s : *sources)
      *out++ = s < 0 ? 0xFF000000u : image.rgba(s % image.width, s / image.width);
    return;
  }
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u) *out++ = image.rgba(u, v);
}

}  // namespace

void pack_rgba(const ColorView& image, std::vector<std::uint32_t>& out) {
  out.resize(static_cast<std::size_t>(image.width) * image.height);
  pack(image, out.data());
}

Status upload_rgba(const ColorView& image, Buffer& buffer, std::vector<std::uint32_t>& scratch,
                   const std::vector<std::int32_t>* sources) {
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  if (sources != nullptr && !sources->empty() && sources->size() != pixels)
    return make_error(ErrorCode::kInvalidArgument, "colour frame of " + std::to_string(pixels) +
                                                       " pixels, the undistortion has " +
                                                       std::to_string(sources->size()));
  if (buffer.mapped() != nullptr && buffer.size() >= pixels * 4) {
    pack(image, static_cast<std::uint32_t*>(buffer.mapped()), sources);
    return {};
  }
  scratch.resize(pixels);
  pack(image, scratch.data(), sources);
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
