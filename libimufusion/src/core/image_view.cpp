#include "imufusion/image_view.hpp"

#include <cmath>
#include <cstring>
#include <string>

namespace imufusion {
namespace {

std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// The checks DepthView and ColorView share: pointer, size, stride and buffer length.
Status check_layout(const char* what, const void* data, int width, int height,
                    std::size_t pixel_bytes, std::size_t stride_bytes, std::size_t buffer_bytes,
                    int expected_width, int expected_height) {
  const std::string name(what);
  if (width != expected_width || height != expected_height)
    return make_error(ErrorCode::kInvalidArgument, name + " is " + size_text(width, height) +
                                                       ", expected " +
                                                       size_text(expected_width, expected_height));
  if (data == nullptr)
    return make_error(ErrorCode::kInvalidArgument, name + " has a null data pointer");
  const std::size_t row = pixel_bytes * static_cast<std::size_t>(width);
  if (stride_bytes != 0 && (stride_bytes < row || stride_bytes % pixel_bytes != 0))
    return make_error(ErrorCode::kInvalidArgument,
                      name + " row stride is " + std::to_string(stride_bytes) +
                          " bytes, expected a multiple of " + std::to_string(pixel_bytes) +
                          " of at least " + std::to_string(row) + " (" + std::to_string(width) +
                          " pixels)");
  const std::size_t stride = stride_bytes != 0 ? stride_bytes : row;
  const std::size_t needed = stride * static_cast<std::size_t>(height - 1) + row;
  if (buffer_bytes != 0 && buffer_bytes < needed)
    return make_error(ErrorCode::kInvalidArgument,
                      name + " buffer holds " + std::to_string(buffer_bytes) + " bytes, " +
                          size_text(width, height) + " at a row stride of " +
                          std::to_string(stride) + " bytes needs " + std::to_string(needed));
  return {};
}

}  // namespace

DepthView DepthView::uint16(const std::uint16_t* data, int width, int height, double depth_scale,
                            std::size_t stride_bytes) {
  return {data, width, height, stride_bytes, DepthFormat::kUint16, depth_scale, 0};
}

DepthView DepthView::metres(const float* data, int width, int height, std::size_t stride_bytes) {
  return {data, width, height, stride_bytes, DepthFormat::kFloatMetres, 1.0, 0};
}

DepthView DepthView::depth16(const std::uint16_t* data, int width, int height,
                             std::size_t stride_bytes) {
  return {data, width, height, stride_bytes, DepthFormat::kDepth16, 1000.0, 0};
}

Status DepthView::check(int expected_width, int expected_height) const {
  IMUFUSION_RETURN_IF_ERROR(check_layout("depth frame", data, width, height, pixel_bytes(),
                                         stride_bytes, buffer_bytes, expected_width,
                                         expected_height));
  if (format == DepthFormat::kUint16 && !(depth_scale > 0 && std::isfinite(depth_scale)))
    return make_error(ErrorCode::kInvalidArgument,
                      "depth_scale must be positive, got " + std::to_string(depth_scale));
  return {};
}

std::uint32_t ColorView::rgba(int u, int v) const {
  const std::uint8_t* p = data + static_cast<std::size_t>(v) * row_bytes() +
                          pixel_bytes() * static_cast<std::size_t>(u);
  const bool bgr = format == ColorFormat::kBgra8;
  return std::uint32_t{p[bgr ? 2 : 0]} | (std::uint32_t{p[1]} << 8) |
         (std::uint32_t{p[bgr ? 0 : 2]} << 16) | 0xFF000000u;
}

Status ColorView::check(int expected_width, int expected_height) const {
  return check_layout("colour frame", data, width, height, pixel_bytes(), stride_bytes,
                      buffer_bytes, expected_width, expected_height);
}

}  // namespace imufusion
