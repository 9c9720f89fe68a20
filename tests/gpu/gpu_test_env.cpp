#include "gpu_test_env.hpp"

#include <cstdlib>
#include <iostream>
#include <string>

namespace imufusion::test {
namespace {

bool gpu_required() {
  for (const char* name : {"IMUFUSION_REQUIRE_GPU", "CI"}) {
    const char* value = std::getenv(name);
    if (value != nullptr && *value != '\0' && std::string(value) != "0" &&
        std::string(value) != "false")
      return true;
  }
  return false;
}

}  // namespace

std::shared_ptr<gpu::Context> gpu_context(std::string* reason) {
  static std::string failure;
  static std::shared_ptr<gpu::Context> context = [] {
    DeviceOptions options;
    options.validation = true;
    auto created = gpu::Context::create(options);
    if (!created) {
      failure = created.error().describe();
      return std::shared_ptr<gpu::Context>();
    }
    const auto& info = (*created)->info();
    std::cout << "[gpu] running on " << info.name << " (" << to_string(info.type) << ", "
              << info.driver << "), validation layer "
              << ((*created)->validation_enabled() ? "on" : "not installed") << std::endl;
    return *created;
  }();
  if (reason != nullptr) *reason = failure;
  return context;
}

void GpuTest::SetUp() {
  std::string reason;
  context_ = gpu_context(&reason);
  if (!context_) {
    if (gpu_required()) {
      FAIL() << "no Vulkan device, and GPU tests are required here (CI / IMUFUSION_REQUIRE_GPU): "
             << reason;
    }
    GTEST_SKIP() << "no Vulkan device: " << reason;
  }
  validation_errors_before_ = context_->validation_error_count();
}

void GpuTest::TearDown() {
  if (!context_) return;
  const std::uint32_t errors = context_->validation_error_count() - validation_errors_before_;
  if (errors > 0) {
    const auto messages = context_->validation_messages();
    std::string text;
    for (std::size_t i = messages.size() - errors; i < messages.size(); ++i)
      text += "\n" + messages[i];
    ADD_FAILURE() << errors << " Vulkan validation error(s) during this test:" << text;
  }
}

}  // namespace imufusion::test
