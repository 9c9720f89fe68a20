#include "io/atomic_file.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <random>
#include <system_error>

namespace imufusion::io {
namespace {

// 8 hex digits that differ between processes (random seed) and between calls (counter), so two
// writers of the same path never share a temporary file.
std::string temp_suffix() {
  static const std::uint32_t seed = std::random_device{}();
  static std::atomic<std::uint32_t> counter{0};
  std::uint32_t value = seed ^ (counter.fetch_add(1) * 2654435761u);
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "%08x", static_cast<unsigned>(value));
  return buffer;
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

Status write_file_atomically(const std::filesystem::path& path,
                             const std::function<Status(std::FILE*)>& write) {
  std::filesystem::path temp;
  std::FILE* file = nullptr;
  // "x": exclusive creation, so an unlucky name clash is retried rather than shared.
  for (int attempt = 0; attempt < 8 && file == nullptr; ++attempt) {
    temp = path;
    temp += ".tmp-" + temp_suffix();
    file = std::fopen(temp.c_str(), "wbx");
    if (file == nullptr && errno != EEXIST) break;
  }
  if (file == nullptr) {
    return make_error(ErrorCode::kIoError, "cannot create " + temp.string() + " to write " +
                                               path.string() + ": " + errno_text());
  }
  Status status = write(file);
  if (status.ok() && std::fflush(file) != 0) {
    status = make_error(ErrorCode::kIoError, "cannot write " + path.string() + ": " + errno_text());
  }
  if (std::fclose(file) != 0 && status.ok()) {
    status = make_error(ErrorCode::kIoError, "cannot write " + path.string() + ": " + errno_text());
  }
  std::error_code ec;
  if (status.ok()) {
    std::filesystem::rename(temp, path, ec);
    if (ec) {
      status = make_error(ErrorCode::kIoError, "cannot rename " + temp.string() + " to " +
                                                   path.string() + ": " + ec.message());
    }
  }
  if (!status.ok()) std::filesystem::remove(temp, ec);
  return status;
}

Status write_text_atomically(const std::filesystem::path& path, std::string_view content) {
  return write_file_atomically(path, [&](std::FILE* file) -> Status {
    if (!content.empty() &&
        std::fwrite(content.data(), 1, content.size(), file) != content.size()) {
      return make_error(ErrorCode::kIoError, "cannot write " + path.string() + ": " + errno_text());
    }
    return {};
  });
}

Result<std::vector<std::uint8_t>> read_file_bytes(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return make_error(ErrorCode::kNotFound, path.string() + ": no such file");
  }
  if (std::filesystem::is_directory(path, ec)) {
    return make_error(ErrorCode::kIoError, path.string() + ": is a directory, not a file");
  }
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) {
    return make_error(ErrorCode::kIoError, "cannot open " + path.string() + ": " + errno_text());
  }
  std::vector<std::uint8_t> bytes;
  std::uint8_t chunk[1 << 16];
  std::size_t n = 0;
  while ((n = std::fread(chunk, 1, sizeof(chunk), file)) > 0) {
    bytes.insert(bytes.end(), chunk, chunk + n);
  }
  const bool failed = std::ferror(file) != 0;
  std::fclose(file);
  if (failed) {
    return make_error(ErrorCode::kIoError, "cannot read " + path.string() + ": " + errno_text());
  }
  return bytes;
}

}  // namespace imufusion::io
