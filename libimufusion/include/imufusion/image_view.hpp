#pragma once
// Non-owning views of a caller's depth and colour frames: rows `stride_bytes` apart (0 = packed),
// read in place while the call that takes them runs.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "imufusion/result.hpp"

namespace imufusion {

/// How a depth pixel is stored.
enum class DepthFormat {
  kUint16,       // raw units, depth_scale per metre; 0 = no measurement
  kFloatMetres,  // float metres; 0, negative or NaN = no measurement
  kDepth16,      // Android DEPTH16: low 13 bits millimetres, top 3 bits confidence (see below)
};

/// A depth frame in the caller's memory. kDepth16's confidence code 1 (0% confidence) counts as
/// no measurement; every other code (0 = 100%, 2..7 = 1/7..6/7) keeps the range.
struct DepthView {
  const void* data = nullptr;
  int width = 0, height = 0;
  std::size_t stride_bytes = 0;  // bytes from one row's start to the next; 0 = packed rows
  DepthFormat format = DepthFormat::kUint16;
  double depth_scale = 5000.0;   // raw units per metre (kUint16 only; kDepth16 is 1000)
  std::size_t buffer_bytes = 0;  // bytes readable at data, when known (0 = not checked)

  static DepthView uint16(const std::uint16_t* data, int width, int height, double depth_scale,
                          std::size_t stride_bytes = 0);
  static DepthView metres(const float* data, int width, int height, std::size_t stride_bytes = 0);
  static DepthView depth16(const std::uint16_t* data, int width, int height,
                           std::size_t stride_bytes = 0);

  std::size_t pixel_bytes() const { return format == DepthFormat::kFloatMetres ? 4 : 2; }
  /// Bytes between row starts (stride_bytes, or the packed row's size).
  std::size_t row_bytes() const {
    return stride_bytes != 0 ? stride_bytes : pixel_bytes() * static_cast<std::size_t>(width);
  }
  const std::byte* row(int v) const {
    return static_cast<const std::byte*>(data) + static_cast<std::size_t>(v) * row_bytes();
  }
  /// The raw value at (u, v) as a uint16 in depth_scale units (DEPTH16 decoded to millimetres,
  /// 0 at confidence 0%); for kFloatMetres use metres().
  std::uint16_t raw(int u, int v) const;
  /// Metres at (u, v); 0 where there is no measurement.
  double metres(int u, int v) const;
  /// Raw units per metre of raw() (1000 for kDepth16).
  double raw_scale() const { return format == DepthFormat::kDepth16 ? 1000.0 : depth_scale; }

  /// Refuses a null pointer, a row stride shorter than a row, an unaligned stride, a
  /// non-positive depth_scale, a size other than width x height, or a buffer too short; the
  /// message names the actual and expected values.
  Status check(int expected_width, int expected_height) const;
};

// Inline: the host's per-frame statistics read every pixel through these.
inline std::uint16_t DepthView::raw(int u, int v) const {
  std::uint16_t value = 0;
  std::memcpy(&value, row(v) + 2 * static_cast<std::size_t>(u), sizeof value);
  if (format != DepthFormat::kDepth16) return value;
  return (value >> 13) == 1 ? 0 : static_cast<std::uint16_t>(value & 0x1FFF);
}

inline double DepthView::metres(int u, int v) const {
  if (format == DepthFormat::kFloatMetres) {
    float value = 0;
    std::memcpy(&value, row(v) + 4 * static_cast<std::size_t>(u), sizeof value);
    return value > 0 && std::isfinite(value) ? value : 0.0;
  }
  return raw(u, v) * (1.0 / raw_scale());
}

/// How a colour pixel is stored: 8 bits per channel.
enum class ColorFormat { kRgb8, kRgba8, kBgra8 };

/// A colour frame registered to the depth frame (same size), in the caller's memory.
struct ColorView {
  const std::uint8_t* data = nullptr;
  int width = 0, height = 0;
  std::size_t stride_bytes = 0;  // bytes from one row's start to the next; 0 = packed rows
  ColorFormat format = ColorFormat::kRgb8;
  std::size_t buffer_bytes = 0;  // bytes readable at data, when known (0 = not checked)

  std::size_t pixel_bytes() const { return format == ColorFormat::kRgb8 ? 3 : 4; }
  std::size_t row_bytes() const {
    return stride_bytes != 0 ? stride_bytes : pixel_bytes() * static_cast<std::size_t>(width);
  }
  /// The pixel at (u, v) packed as 0xAABBGGRR with alpha 255.
  std::uint32_t rgba(int u, int v) const;
  /// As DepthView::check.
  Status check(int expected_width, int expected_height) const;
};

}  // namespace imufusion
