// Device selection policy, without Vulkan: discrete, then integrated, virtual, CPU; selectors.

#include <gtest/gtest.h>

#include "vk/context.hpp"
#include "vk/vk_error.hpp"

namespace imufusion {
namespace {

std::vector<DeviceInfo> devices() {
  std::vector<DeviceInfo> list(3);
  list[0] = {0, "llvmpipe (LLVM 15.0.6, 256 bits)", DeviceType::kCpu, "", 0, 0, true};
  list[1] = {1, "Intel(R) UHD Graphics 620", DeviceType::kIntegratedGpu, "", 0, 0, true};
  list[2] = {2, "NVIDIA GeForce RTX 3080", DeviceType::kDiscreteGpu, "", 0, 0, true};
  return list;
}

TEST(DeviceSelect, PrefersDiscreteThenIntegratedThenCpu) {
  auto list = devices();
  EXPECT_EQ(*gpu::select_device(list, ""), 2);
  list.pop_back();
  EXPECT_EQ(*gpu::select_device(list, ""), 1);
  list.pop_back();
  EXPECT_EQ(*gpu::select_device(list, ""), 0);
}

TEST(DeviceSelect, ByIndexOrCaseInsensitiveNameSubstring) {
  const auto list = devices();
  EXPECT_EQ(*gpu::select_device(list, "0"), 0);
  EXPECT_EQ(*gpu::select_device(list, "1"), 1);
  EXPECT_EQ(*gpu::select_device(list, "LLVMPIPE"), 0);
  EXPECT_EQ(*gpu::select_device(list, "nvidia"), 2);
}

TEST(DeviceSelect, NoMatchOrNoDeviceIsAnError) {
  auto none = gpu::select_device(devices(), "amd");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::kNoDevice);
  EXPECT_NE(none.error().message.find("NVIDIA GeForce RTX 3080"), std::string::npos);
  EXPECT_FALSE(gpu::select_device(devices(), "7").ok());
  EXPECT_FALSE(gpu::select_device({}, "").ok());
}

}  // namespace
}  // namespace imufusion

namespace imufusion {
namespace {

TEST(VkErrorMapping, DeviceLossAndMemoryExhaustionHaveTheirOwnCodes) {
  const Error lost = gpu::vk_error(VK_ERROR_DEVICE_LOST, "vkQueueSubmit");
  EXPECT_EQ(lost.code, ErrorCode::kDeviceLost);
  EXPECT_EQ(lost.vk_result, VK_ERROR_DEVICE_LOST);
  EXPECT_NE(lost.describe().find("VK_ERROR_DEVICE_LOST"), std::string::npos);
  EXPECT_EQ(gpu::vk_error(VK_ERROR_OUT_OF_DEVICE_MEMORY, "x").code, ErrorCode::kOutOfDeviceMemory);
  EXPECT_EQ(gpu::vk_error(VK_ERROR_OUT_OF_HOST_MEMORY, "x").code, ErrorCode::kOutOfDeviceMemory);
  EXPECT_EQ(gpu::vk_error(VK_ERROR_INCOMPATIBLE_DRIVER, "x").code, ErrorCode::kNoDevice);
  EXPECT_EQ(gpu::vk_error(VK_ERROR_FEATURE_NOT_PRESENT, "x").code, ErrorCode::kVulkanError);
}

}  // namespace
}  // namespace imufusion
