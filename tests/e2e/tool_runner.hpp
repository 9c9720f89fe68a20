#pragma once
// Runs a built tool in a scratch directory and captures its exit code, stdout and stderr.

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

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

/// A fresh directory under the system temp directory, removed with the object.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& prefix) {
    std::random_device random;
    path_ = std::filesystem::temp_directory_path() / (prefix + std::to_string(random()));
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

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
