// libFuzzer harness: one file's bytes through the PNG decoders that read depth and colour frames
// (png_codec.hpp, in memory as read_depth_png and read_color_image call them), then, when a depth
// image decodes, through the encoder and back (the recorder's round trip). libpng refuses a chunk
// whose CRC is wrong, so the mutator rewrites the CRCs of every other mutant: header and
// ancillary chunk changes then reach the decoder. Built and run by .ci/run (clang
// -fsanitize=fuzzer,address,undefined, linked with libpng and zlib).

#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "io/png_codec.hpp"

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace {

std::uint32_t load_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

// Rewrites the CRC of each whole chunk after the 8-byte signature.
void fix_chunk_crcs(std::uint8_t* data, std::size_t size) {
  std::size_t at = 8;
  while (at + 12 <= size) {
    const std::uint32_t length = load_be32(data + at);
    if (length > size - at - 12) return;
    const std::uint8_t* type = data + at + 4;
    const auto crc = static_cast<std::uint32_t>(crc32(0, type, 4 + length));
    std::uint8_t* out = data + at + 8 + length;
    for (int b = 0; b < 4; ++b) out[b] = static_cast<std::uint8_t>(crc >> (24 - 8 * b));
    at += 12 + length;
  }
}

// Re-encodes a decoded depth image into a memory stream and decodes it again: it must survive.
void round_trip(const imufusion::DepthImage& image) {
  char* buffer = nullptr;
  std::size_t size = 0;
  std::FILE* file = open_memstream(&buffer, &size);
  if (file == nullptr) return;
  const auto encoded =
      imufusion::io::encode_png(file, "fuzz.png", image.width, image.height, 1, image.data.data());
  std::fclose(file);
  if (encoded.ok()) {
    const std::vector<std::uint8_t> bytes(buffer, buffer + size);
    const auto again = imufusion::io::decode_depth_png(bytes, "fuzz.png", 1000.0);
    if (!again.ok() || again->data != image.data) __builtin_trap();
  }
  std::free(buffer);
}

}  // namespace

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size,
                                               std::size_t max_size, unsigned int seed) {
  size = LLVMFuzzerMutate(data, size, max_size);
  if (seed % 2 == 0) fix_chunk_crcs(data, size);
  return size;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<std::uint8_t> bytes(data, data + size);
  const auto depth = imufusion::io::decode_depth_png(bytes, "fuzz.png", 1000.0);
  if (depth.ok()) {
    if (depth->data.size() != static_cast<std::size_t>(depth->width) * depth->height) {
      __builtin_trap();
    }
    // Larger images make each run slow without reaching new code in the encoder.
    if (depth->data.size() <= 4096) round_trip(*depth);
  }
  const auto color = imufusion::io::decode_color_png(bytes, "fuzz.png");
  if (color.ok() &&
      color->data.size() != static_cast<std::size_t>(color->width) * color->height * 3) {
    __builtin_trap();
  }
  return 0;
}
