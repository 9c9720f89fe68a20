#include "io/text_table.hpp"

#include <charconv>
#include <cmath>

#include "io/atomic_file.hpp"

namespace imufusion::io {
namespace {

bool is_separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == '\v' || c == '\f'; }

}  // namespace

std::vector<std::string> split_fields(std::string_view text) {
  std::vector<std::string> fields;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && is_separator(text[i])) ++i;
    const std::size_t start = i;
    while (i < text.size() && !is_separator(text[i])) ++i;
    if (i > start) fields.emplace_back(text.substr(start, i - start));
  }
  return fields;
}

Result<std::vector<TextLine>> read_text_table(const std::filesystem::path& path) {
  auto bytes = read_file_bytes(path, kMaxTextFileBytes);
  if (!bytes.ok()) return bytes.error();
  const std::string_view content(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  std::vector<TextLine> lines;
  int number = 0;
  std::size_t pos = 0;
  while (pos < content.size()) {
    std::size_t end = content.find('\n', pos);
    if (end == std::string_view::npos) end = content.size();
    std::string_view text = content.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    if (text.find('\0') != std::string_view::npos) {
      return make_error(ErrorCode::kParseError,
                        where(path, number) + "contains a NUL byte (not a text file?)");
    }
    std::vector<std::string> fields = split_fields(text);
    if (fields.empty() || fields.front().front() == '#') continue;
    lines.push_back(TextLine{number, std::string(text), std::move(fields)});
  }
  return lines;
}

std::string where(const std::filesystem::path& path, int line) {
  return path.string() + ":" + std::to_string(line) + ": ";
}

Result<double> parse_finite(std::string_view field, const std::filesystem::path& path, int line,
                            std::string_view what) {
  std::string_view digits = field;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  double value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec != std::errc() || end != digits.data() + digits.size() || digits.empty()) {
    return make_error(ErrorCode::kParseError, where(path, line) + std::string(what) + " '" +
                                                  std::string(field) + "' is not a number");
  }
  if (!std::isfinite(value)) {
    return make_error(ErrorCode::kParseError, where(path, line) + std::string(what) + " '" +
                                                  std::string(field) + "' is not finite");
  }
  return value;
}

Result<long long> parse_integer(std::string_view field, const std::filesystem::path& path, int line,
                                std::string_view what, long long min_value, long long max_value) {
  long long value = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || end != field.data() + field.size() || field.empty()) {
    return make_error(ErrorCode::kParseError, where(path, line) + std::string(what) + " '" +
                                                  std::string(field) + "' is not an integer");
  }
  if (value < min_value || value > max_value) {
    return make_error(ErrorCode::kParseError, where(path, line) + std::string(what) + " " +
                                                  std::string(field) + " is outside [" +
                                                  std::to_string(min_value) + ", " +
                                                  std::to_string(max_value) + "]");
  }
  return value;
}

Status expect_fields(const TextLine& line, std::size_t count, const std::filesystem::path& path,
                     std::string_view layout) {
  if (line.fields.size() == count) return {};
  return make_error(ErrorCode::kParseError,
                    where(path, line.number) + "expected " + std::to_string(count) + " fields (" +
                        std::string(layout) + "), found " + std::to_string(line.fields.size()) +
                        ": '" + line.text + "'");
}

std::string format_exact(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  if (ec != std::errc()) return std::to_string(value);
  return std::string(buffer, end);
}

}  // namespace imufusion::io
