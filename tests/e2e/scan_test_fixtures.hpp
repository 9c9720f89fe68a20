#pragma once
// Shared by the imufusion-scan e2e tests: the tool, a scratch directory per test, small
// synthetic sequences (160x120) and summary.json.

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "../support/synth_config.hpp"
#include "imufusion/synth.hpp"
#include "tool_runner.hpp"

namespace imufusion::test {

inline const std::filesystem::path kScanTool =
    std::filesystem::path(IMUFUSION_TEST_BINARY_DIR) / "tools" / "imufusion-scan";

inline nlohmann::json read_json(const std::filesystem::path& path) {
  return nlohmann::json::parse(read_text(path));
}

/// A 160x120 synthetic sequence of `scene` written to root/name; `white_noise`: the Kinect's
/// noise independent per pixel (SynthConfig::white_depth_noise).
inline std::filesystem::path synthesize_small(const std::filesystem::path& root,
                                              const std::string& name, synth::SceneKind scene,
                                              int frames, std::uint64_t seed,
                                              bool white_noise = false) {
  const std::filesystem::path dir = root / name;
  synth::SynthConfig config = test::small_synth_config(scene, seed, frames);
  config.white_depth_noise = white_noise;
  auto summary = synth::synthesize(config, dir);
  EXPECT_TRUE(summary.ok()) << summary.error().describe();
  return dir;
}

/// Runs imufusion-scan in a scratch directory of its own.
class ScanToolTest : public ::testing::Test {
 protected:
  explicit ScanToolTest(const std::string& prefix) : scratch_(prefix) {}
  void SetUp() override {
    ASSERT_TRUE(std::filesystem::exists(kScanTool)) << kScanTool << " was not built";
  }
  ToolRun scan(const std::string& args) { return run_tool(kScanTool, args, scratch_.path()); }
  std::filesystem::path path(const std::string& name) const { return scratch_.path() / name; }

  ScratchDir scratch_;
};

}  // namespace imufusion::test
