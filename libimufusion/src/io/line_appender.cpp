#include "io/line_appender.hpp"

#include <cerrno>
#include <cstring>

namespace imufusion::io {
namespace {

Error failure(const char* what, const std::filesystem::path& path) {
  return make_error(ErrorCode::kIoError,
                    std::string(what) + " " + path.string() + ": " + std::strerror(errno));
}

}  // namespace

Status LineAppender::append(const std::filesystem::path& path, const std::string& header,
                            const std::string& line) {
  if (file_ == nullptr) {
    file_ = std::fopen(path.c_str(), "wb");
    if (file_ == nullptr) return failure("cannot create", path);
    if (std::fputs(header.c_str(), file_) < 0) return failure("cannot write", path);
  }
  if (std::fputs(line.c_str(), file_) < 0 || std::fflush(file_) != 0) {
    return failure("cannot write", path);
  }
  return {};
}

void LineAppender::close() {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
}

}  // namespace imufusion::io
