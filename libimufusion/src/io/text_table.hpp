#pragma once
// The line grammar shared by every text file of the sequence format (FORMAT.md): `#` starts a
// comment line, blank lines are skipped, fields are separated by spaces (tabs and commas are
// accepted too, as TUM's associate.py does), and a trailing '\r' is ignored.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "imufusion/result.hpp"

namespace imufusion::io {

/// One data line of a text file.
struct TextLine {
  int number = 0;                   // 1-based line number in the file
  std::string text;                 // the line without its trailing '\r'
  std::vector<std::string> fields;  // whitespace/comma separated
};

/// The fields of one line, split at spaces, tabs and commas.
std::vector<std::string> split_fields(std::string_view text);

/// The largest text file read (bytes): 512 MiB, about 5 hours of a 200 Hz imu.txt.
inline constexpr std::uint64_t kMaxTextFileBytes = std::uint64_t{512} << 20;

/// Reads `path` (a regular file of at most kMaxTextFileBytes) and splits every non-comment,
/// non-blank line into fields.
Result<std::vector<TextLine>> read_text_table(const std::filesystem::path& path);

/// "PATH:LINE: " — the prefix of every message about a line.
std::string where(const std::filesystem::path& path, int line);

/// Parses a finite double. Fails with kParseError naming file, line, `what` and the offending
/// text when the field is not a number or is NaN/inf.
Result<double> parse_finite(std::string_view field, const std::filesystem::path& path, int line,
                            std::string_view what);

/// Parses a whole decimal integer in [min_value, max_value].
Result<long long> parse_integer(std::string_view field, const std::filesystem::path& path, int line,
                                std::string_view what, long long min_value, long long max_value);

/// Fails unless `line` has exactly `count` fields; the message shows the expected layout.
Status expect_fields(const TextLine& line, std::size_t count, const std::filesystem::path& path,
                     std::string_view layout);

/// Shortest text that reads back to exactly `value` (std::to_chars).
std::string format_exact(double value);

}  // namespace imufusion::io
