#pragma once
// Strict number parsing for the command-line tools: the whole argument must be the number.

#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>

namespace imufusion::tools {

/// A finite decimal number, or nullopt for anything else ("", "1.5x", "nan", "inf").
inline std::optional<double> parse_number(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

/// A base-10 integer, or nullopt for anything else.
inline std::optional<long long> parse_integer(const std::string& text) {
  if (text.empty()) return std::nullopt;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return value;
}

}  // namespace imufusion::tools
