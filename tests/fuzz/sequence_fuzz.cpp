// libFuzzer harness: the text files of a sequence (FORMAT.md) through imufusion-info's check
// (check_sequence: every index parsed, every listed image decoded) and, when that says
// scannable, through SequenceReader, which must then open and read every frame. The input is cut
// at each 0x1E byte into the contents of kFiles, in order; an empty or missing part leaves that
// file out. The files go to a temporary directory holding two images an index may name: d.png
// (8x8 16-bit depth, the smallest a scan takes) and c.png (8x8 RGB). Built and run by .ci/run
// (clang -fsanitize=fuzzer,address,undefined, linked with libpng).

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "imufusion/sequence.hpp"
#include "io/png_codec.hpp"
#include "io/sequence_check.hpp"

namespace {

namespace fs = std::filesystem;

constexpr const char* kFiles[] = {"depth.txt",         "calibration.txt",  "info.txt",
                                  "rgb.txt",           "imu.txt",          "groundtruth.txt",
                                  "imu_to_camera.txt", "accelerometer.txt"};
constexpr char kSeparator = '\x1e';

fs::path sequence_directory;

void remove_directory() { fs::remove_all(sequence_directory); }

void write_png(const fs::path& path, int channels, const void* pixels) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr || !imufusion::io::encode_png(file, path, 8, 8, channels, pixels).ok()) {
    std::abort();
  }
  std::fclose(file);
}

// The temporary sequence directory with its two images, made once per process.
const fs::path& directory() {
  if (!sequence_directory.empty()) return sequence_directory;
  char name[] = "/tmp/imufusion-sequence-fuzz-XXXXXX";
  if (::mkdtemp(name) == nullptr) std::abort();
  sequence_directory = name;
  std::atexit(remove_directory);
  std::vector<std::uint16_t> depth(64);
  for (std::size_t i = 0; i < depth.size(); ++i) depth[i] = static_cast<std::uint16_t>(800 + i);
  write_png(sequence_directory / "d.png", 1, depth.data());
  const std::vector<std::uint8_t> color(192, 128);
  write_png(sequence_directory / "c.png", 3, color.data());
  return sequence_directory;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fs::path& dir = directory();
  std::string_view input(reinterpret_cast<const char*>(data), size);
  for (const char* file : kFiles) {
    const std::size_t end = std::min(input.find(kSeparator), input.size());
    const std::string_view part = input.substr(0, end);
    input.remove_prefix(std::min(end + 1, input.size()));
    if (part.empty()) {
      fs::remove(dir / file);
    } else {
      std::ofstream(dir / file, std::ios::binary).write(part.data(), std::ssize(part));
    }
  }
  const imufusion::io::SequenceCheck check = imufusion::io::check_sequence(dir, nullptr);
  if (!check.scannable) return 0;
  // imufusion-info said scannable: a scan must then be able to read every frame.
  auto reader = imufusion::SequenceReader::open(dir);
  if (!reader.ok()) __builtin_trap();
  while (!reader->done()) {
    if (!reader->next().ok()) __builtin_trap();
  }
  return 0;
}
