#pragma once
// The JSON text the tools print and write (summary.json, --json). A string may hold bytes that
// are not UTF-8 (a path, a line received over UDP): each such byte is written as U+FFFD, so a
// report is always written and always parses.

#include <nlohmann/json.hpp>
#include <string>

namespace imufusion::tools {

inline std::string json_text(const nlohmann::json& value, int indent = 2) {
  return value.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace imufusion::tools
