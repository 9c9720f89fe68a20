#pragma once
// Runs a built tool in a scratch directory and captures its exit code, stdout and stderr.

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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
  const std::string command =
      tool.string() + " " + args + " > " + out.string() + " 2> " + err.string();
  const int status = std::system(command.c_str());
  ToolRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.out = read_text(out);
  run.err = read_text(err);
  return run;
}

/// Starts `tool args...` in the background, stdout and stderr into scratch/tool_stdout.txt and
/// scratch/tool_stderr.txt; returns its process id (-1 when it could not start).
inline pid_t spawn_tool(const std::filesystem::path& tool, const std::vector<std::string>& args,
                        const std::filesystem::path& scratch) {
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  const std::string out = (scratch / "tool_stdout.txt").string(),
                    err = (scratch / "tool_stderr.txt").string();
  posix_spawn_file_actions_addopen(&files, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_addopen(&files, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  std::vector<std::string> argv_text = {tool.string()};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &files, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  return rc == 0 ? pid : -1;
}

/// Waits for a spawned tool; its exit code, or 128 + the signal that ended it.
inline int wait_tool(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace imufusion::test
