#pragma once
// Helpers shared by the io tests: a self-deleting temporary directory and small file writers.

#include <gtest/gtest.h>
#include <png.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "imufusion/types.hpp"

namespace imufusion::testing {

/// A fresh directory under the system temp dir, removed with its content on destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device random;
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = "imufusion_io_";
    if (test != nullptr) name += std::string(test->test_suite_name()) + "_" + test->name() + "_";
    name += std::to_string(random()) + std::to_string(random());
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
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

/// Writes a PNG with libpng's simplified API, independently of imufusion's writer. `format` is a
/// PNG_FORMAT_* value; `pixels` holds bytes, or uint16 for the linear (16-bit) formats.
inline bool write_png_simplified(const std::filesystem::path& path, int width, int height,
                                 png_uint_32 format, const void* pixels) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = format;
  return png_image_write_to_file(&image, path.c_str(), 0, pixels, 0, nullptr) != 0;
}

}  // namespace imufusion::testing
