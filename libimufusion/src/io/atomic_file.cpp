#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <mutex>
#include <random>
#include <set>
#include <system_error>

namespace imufusion::io {
namespace {

namespace fs = std::filesystem;

// 8 hex digits that differ between processes (random seed) and between calls (counter), so two
// writers of the same path never share a temporary file.
std::string temp_suffix() {
  static const std::uint32_t seed = std::random_device{}();
  static std::atomic<std::uint32_t> counter{0};
  std::uint32_t value = seed ^ (counter.fetch_add(1) * 2654435761u);
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%ld-%08x", static_cast<long>(::getpid()),
                static_cast<unsigned>(value));
  return buffer;
}

std::string errno_text() { return std::strerror(errno); }

bool all_hex(std::string_view text) {
  return !text.empty() && text.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

// The writer of a temporary named `*.tmp-PID-XXXXXXXX` is gone (no such process), or the name
// has the older `*.tmp-XXXXXXXX` form without a process id.
bool is_stale_temporary(const std::string& name) {
  const std::size_t tag = name.rfind(".tmp-");
  if (tag == std::string::npos) return false;
  const std::string_view rest = std::string_view(name).substr(tag + 5);
  const std::size_t dash = rest.find('-');
  if (dash == std::string_view::npos) return rest.size() == 8 && all_hex(rest);
  if (rest.size() - dash - 1 != 8 || !all_hex(rest.substr(dash + 1))) return false;
  long pid = 0;
  const auto [end, ec] = std::from_chars(rest.data(), rest.data() + dash, pid);
  if (ec != std::errc() || end != rest.data() + dash || pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

// Cleans each directory once per process: later leftovers can only come from writers that died
// while this one ran.
void clean_directory_once(const fs::path& directory) {
  static std::mutex mutex;
  static std::set<fs::path> cleaned;
  {
    std::lock_guard lock(mutex);
    if (!cleaned.insert(directory).second) return;
  }
  remove_stale_temporaries(directory);
}

}  // namespace

std::size_t remove_stale_temporaries(const fs::path& directory) {
  std::error_code ec;
  std::size_t removed = 0;
  for (fs::directory_iterator it(directory.empty() ? fs::path(".") : directory, ec), end;
       !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (!it->is_regular_file(type_ec)) continue;
    if (is_stale_temporary(it->path().filename().string()) && fs::remove(it->path(), type_ec)) {
      ++removed;
    }
  }
  return removed;
}

Status write_file_atomically(const fs::path& path, const std::function<Status(std::FILE*)>& write) {
  clean_directory_once(path.parent_path());
  fs::path temp;
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
    fs::rename(temp, path, ec);
    if (ec) {
      status = make_error(ErrorCode::kIoError, "cannot rename " + temp.string() + " to " +
                                                   path.string() + ": " + ec.message());
    }
  }
  if (!status.ok()) fs::remove(temp, ec);
  return status;
}

Status write_text_atomically(const fs::path& path, std::string_view content) {
  return write_file_atomically(path, [&](std::FILE* file) -> Status {
    if (!content.empty() &&
        std::fwrite(content.data(), 1, content.size(), file) != content.size()) {
      return make_error(ErrorCode::kIoError, "cannot write " + path.string() + ": " + errno_text());
    }
    return {};
  });
}

Result<std::vector<std::uint8_t>> read_file_bytes(const fs::path& path, std::uint64_t max_bytes) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return make_error(ErrorCode::kNotFound, path.string() + ": no such file");
    return make_error(ErrorCode::kIoError, "cannot open " + path.string() + ": " + errno_text());
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    Error error =
        make_error(ErrorCode::kIoError, "cannot stat " + path.string() + ": " + errno_text());
    ::close(fd);
    return error;
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    if (S_ISDIR(st.st_mode)) {
      return make_error(ErrorCode::kIoError, path.string() + ": is a directory, not a file");
    }
    return make_error(ErrorCode::kInvalidArgument,
                      path.string() +
                          ": not a regular file (a FIFO, device or socket); only regular files "
                          "are read");
  }
  const auto too_large = [&] {
    return make_error(ErrorCode::kInvalidArgument, path.string() + ": larger than the " +
                                                       std::to_string(max_bytes) +
                                                       "-byte limit for this file");
  };
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
    ::close(fd);
    return too_large();
  }
  std::vector<std::uint8_t> bytes;
  bytes.reserve(static_cast<std::size_t>(st.st_size));
  std::uint8_t chunk[1 << 16];
  while (true) {
    const ssize_t n = ::read(fd, chunk, sizeof(chunk));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      Error error =
          make_error(ErrorCode::kIoError, "cannot read " + path.string() + ": " + errno_text());
      ::close(fd);
      return error;
    }
    if (n == 0) break;
    if (bytes.size() + static_cast<std::size_t>(n) > max_bytes) {  // grew while being read
      ::close(fd);
      return too_large();
    }
    bytes.insert(bytes.end(), chunk, chunk + n);
  }
  ::close(fd);
  return bytes;
}

}  // namespace imufusion::io
