#pragma once
// Runs a built tool in a scratch directory and captures its exit code, stdout and stderr.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "../support/scratch_dir.hpp"

namespace imufusion::test {

struct ToolRun {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Runs `tool args` (args as a shell fragment) with its output captured under `scratch`.
inline ToolRun run_tool(const std::filesystem::path& tool, const std::string& args,
                        const std::filesystem::path& scratch) {
  const auto out = scratch / "tool_stdout.txt", err = scratch / "tool_stderr.txt";
  const std::string command = tool.string() + " " + args + " > " + out.string() + " 2> " + err.string();
  const int status = std::system(command.c_str());
  ToolRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.out = read_text(out);
  run.err = read_text(err);
  return run;
}

}  // namespace imufusion::test
