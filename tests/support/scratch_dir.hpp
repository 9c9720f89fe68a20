#pragma once
// A fresh directory under the system temp directory, removed with the object (also when a test
// stops at a failed assertion).

#include <filesystem>
#include <random>
#include <string>
#include <system_error>

namespace imufusion::test {

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

}  // namespace imufusion::test
