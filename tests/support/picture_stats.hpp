#pragma once
// Counts over an RGB picture for tests of the tools' preview.png and overview.png.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "imufusion/types.hpp"

namespace imufusion::test {

/// The fraction of pixels that are not pure black (0..1).
inline double non_black_fraction(const ColorImage& img) {
  std::size_t lit = 0;
  for (std::size_t i = 0; i + 2 < img.data.size(); i += 3)
    lit += (img.data[i] | img.data[i + 1] | img.data[i + 2]) != 0;
  return img.data.empty() ? 0.0
                          : 3.0 * static_cast<double>(lit) / static_cast<double>(img.data.size());
}

/// The pixels exactly of colour `rgb`.
inline std::size_t pixels_of(const ColorImage& img, const std::array<std::uint8_t, 3>& rgb) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < img.data.size(); i += 3)
    n += img.data[i] == rgb[0] && img.data[i + 1] == rgb[1] && img.data[i + 2] == rgb[2];
  return n;
}

/// The pixels whose channels differ by more than `spread` (0..255): coloured, not grey.
inline std::size_t coloured_pixels(const ColorImage& img, int spread = 24) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < img.data.size(); i += 3) {
    const int r = img.data[i], g = img.data[i + 1], b = img.data[i + 2];
    n += std::abs(r - g) > spread || std::abs(g - b) > spread || std::abs(r - b) > spread;
  }
  return n;
}

}  // namespace imufusion::test
