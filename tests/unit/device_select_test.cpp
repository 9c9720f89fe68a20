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

// Memory tables as drivers report them: lavapipe (one heap, one type with every host flag) and
// a discrete GPU with resizable BAR (device-local host-visible memory, but uncached).
TEST(UnifiedMemory, OnlyCachedHostVisibleDeviceMemoryCounts) {
  VkPhysicalDeviceMemoryProperties cpu{};
  cpu.memoryHeapCount = 1;
  cpu.memoryHeaps[0] = {std::uint64_t{16} << 30, VK_MEMORY_HEAP_DEVICE_LOCAL_BIT};
  cpu.memoryTypeCount = 1;
  cpu.memoryTypes[0] = {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                            VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                            VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                        0};
  EXPECT_TRUE(gpu::has_unified_memory(cpu, cpu.memoryHeaps[0].size));

  VkPhysicalDeviceMemoryProperties rebar{};
  rebar.memoryHeapCount = 2;
  rebar.memoryHeaps[0] = {std::uint64_t{80} << 30, VK_MEMORY_HEAP_DEVICE_LOCAL_BIT};
  rebar.memoryHeaps[1] = {std::uint64_t{64} << 30, 0};
  rebar.memoryTypeCount = 4;
  rebar.memoryTypes[0] = {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0};
  rebar.memoryTypes[1] = {
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 1};
  rebar.memoryTypes[2] = {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                              VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                              VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                          1};
  rebar.memoryTypes[3] = {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT |
                              VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                              VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                          0};
  EXPECT_FALSE(gpu::has_unified_memory(rebar, rebar.memoryHeaps[0].size));
  // A small cached device-local window does not hold the volume either.
  cpu.memoryHeaps[0].size = 256ull << 20;
  EXPECT_FALSE(gpu::has_unified_memory(cpu, std::uint64_t{16} << 30));
}

}  // namespace
}  // namespace imufusion
