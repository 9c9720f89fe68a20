#pragma once
// Helpers shared by the io tests: a self-deleting temporary directory and small file writers.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "../support/scratch_dir.hpp"
#include "imufusion/types.hpp"

namespace imufusion::testing {

/// A ScratchDir named after the running test (imufusion_io_<suite>_<test>_<random>).
class TempDir : public test::ScratchDir {
 public:
  TempDir() : ScratchDir(prefix()) {}
  std::filesystem::path operator/(const std::string& name) const { return path() / name; }

 private:
  static std::string prefix() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = "imufusion_io_";
    if (test != nullptr) name += std::string(test->test_suite_name()) + "_" + test->name() + "_";
    return name;
  }
};

inline void write_text(const std::filesystem::path& path, const std::string& content) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << content;
}

inline std::vector<char> read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void write_bytes(const std::filesystem::path& path, const std::vector<char>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// A depth image whose values cover both bytes of the 16-bit range (0, 1, 255, 256, 65535 and
/// pseudo-random values from `seed`).
inline DepthImage make_depth(int width, int height, unsigned seed, double depth_scale = 5000.0) {
  DepthImage image;
  image.width = width;
  image.height = height;
  image.depth_scale = depth_scale;
  std::mt19937 random(seed);
  image.data.resize(static_cast<std::size_t>(width) * height);
  for (auto& value : image.data) value = static_cast<std::uint16_t>(random() & 0xFFFF);
  const std::uint16_t specials[] = {0, 1, 255, 256, 0x0102, 65535};
  for (std::size_t i = 0; i < std::size(specials) && i < image.data.size(); ++i) {
    image.data[i] = specials[i];
  }
  return image;
}

inline ColorImage make_color(int width, int height, unsigned seed) {
  ColorImage image;
  image.width = width;
  image.height = height;
  std::mt19937 random(seed);
  image.data.resize(static_cast<std::size_t>(width) * height * 3);
  for (auto& value : image.data) value = static_cast<std::uint8_t>(random() & 0xFF);
  return image;
}

/// Encodes a PNG without libpng (deflate "stored" blocks, filter 0), so that the reader is
/// checked against an independent encoder. `samples` are in file order: 16-bit samples
/// big-endian. color_type: 0 gray, 2 RGB, 4 gray+alpha, 6 RGBA. `interlaced`: Adam7.
inline std::vector<char> encode_png_independently(int width, int height, int bit_depth,
                                                  int color_type,
                                                  const std::vector<std::uint8_t>& samples,
                                                  bool interlaced = false) {
  auto crc32 = [](const std::vector<std::uint8_t>& bytes) {
    std::uint32_t crc = 0xFFFFFFFFu;
    for (std::uint8_t byte : bytes) {
      crc ^= byte;
      for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return crc ^ 0xFFFFFFFFu;
  };
  auto put32 = [](std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(std::uint8_t(v >> shift));
  };
  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  auto chunk = [&](const char* type, const std::vector<std::uint8_t>& data) {
    put32(png, static_cast<std::uint32_t>(data.size()));
    std::vector<std::uint8_t> body(type, type + 4);
    body.insert(body.end(), data.begin(), data.end());
    png.insert(png.end(), body.begin(), body.end());
    put32(png, crc32(body));
  };
  std::vector<std::uint8_t> header;
  put32(header, static_cast<std::uint32_t>(width));
  put32(header, static_cast<std::uint32_t>(height));
  header.insert(header.end(), {std::uint8_t(bit_depth), std::uint8_t(color_type), 0, 0,
                               std::uint8_t(interlaced ? 1 : 0)});
  chunk("IHDR", header);

  const int channels = color_type == 0 ? 1 : color_type == 2 ? 3 : color_type == 4 ? 2 : 4;
  const std::size_t pixel_bytes = static_cast<std::size_t>(channels) * (bit_depth / 8);
  // Adam7 passes as (x0, y0, dx, dy); a plain image is one pass (0, 0, 1, 1).
  const std::vector<std::array<int, 4>> passes =
      interlaced
          ? std::vector<std::array<int, 4>>{{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                            {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}}
          : std::vector<std::array<int, 4>>{{0, 0, 1, 1}};
  std::vector<std::uint8_t> raw;  // each row of each pass: filter type 0, then the samples
  for (const auto& [x0, y0, dx, dy] : passes) {
    if (x0 >= width || y0 >= height) continue;  // an empty pass has no rows at all
    for (int v = y0; v < height; v += dy) {
      raw.push_back(0);
      for (int u = x0; u < width; u += dx) {
        const auto at = samples.begin() + (static_cast<std::size_t>(v) * width + u) * pixel_bytes;
        raw.insert(raw.end(), at, at + static_cast<std::ptrdiff_t>(pixel_bytes));
      }
    }
  }
  std::vector<std::uint8_t> zlib = {0x78, 0x01};
  for (std::size_t at = 0; at < raw.size() || at == 0; at += 65535) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - at);
    zlib.push_back(at + n >= raw.size() ? 1 : 0);  // BFINAL, BTYPE 00 (stored)
    zlib.insert(zlib.end(),
                {std::uint8_t(n), std::uint8_t(n >> 8), std::uint8_t(~n), std::uint8_t(~n >> 8)});
    zlib.insert(zlib.end(), raw.begin() + at, raw.begin() + at + n);
    if (raw.empty()) break;
  }
  std::uint32_t a = 1, b = 0;  // Adler-32 of the uncompressed data
  for (std::uint8_t byte : raw) {
    a = (a + byte) % 65521u;
    b = (b + a) % 65521u;
  }
  put32(zlib, (b << 16) | a);
  chunk("IDAT", zlib);
  chunk("IEND", {});
  return std::vector<char>(png.begin(), png.end());
}

inline void write_png_independently(const std::filesystem::path& path, int width, int height,
                                    int bit_depth, int color_type,
                                    const std::vector<std::uint8_t>& samples,
                                    bool interlaced = false) {
  write_bytes(path,
              encode_png_independently(width, height, bit_depth, color_type, samples, interlaced));
}

}  // namespace imufusion::testing
