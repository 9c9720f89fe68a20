#pragma once
// A text file written line by line as the data comes, each line flushed: a process killed while
// writing leaves every complete line on disk (index files of a recording, frames.csv).

#include <cstdio>
#include <filesystem>
#include <string>

#include "imufusion/result.hpp"

namespace imufusion::io {

class LineAppender {
 public:
  LineAppender() = default;
  LineAppender(const LineAppender&) = delete;
  LineAppender& operator=(const LineAppender&) = delete;
  ~LineAppender() { close(); }

  /// Appends `line` (with its newline) to `path`, creating the file with `header` at the first
  /// line; fails naming `path`.
  Status append(const std::filesystem::path& path, const std::string& header,
                const std::string& line);
  void close();

 private:
  std::FILE* file_ = nullptr;
};

}  // namespace imufusion::io
