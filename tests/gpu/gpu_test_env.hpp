#pragma once
// The GPU tests' shared Vulkan context: one per test process, with the Khronos validation layer
// when installed. A test fails if the validation layer reported an error while it ran. Without a
// Vulkan device the tests are skipped with the reason, unless CI or IMUFUSION_REQUIRE_GPU is set,
// where they fail instead.

#include <gtest/gtest.h>

#include <memory>

#include "vk/context.hpp"

namespace imufusion::test {

/// The shared context, or nullptr (with `reason` set) when no device could be opened.
std::shared_ptr<gpu::Context> gpu_context(std::string* reason = nullptr);

class GpuTest : public ::testing::Test {
 protected:
  void SetUp() override;
  void TearDown() override;

  std::shared_ptr<gpu::Context> context_;

 private:
  std::uint32_t validation_errors_before_ = 0;
};

}  // namespace imufusion::test
