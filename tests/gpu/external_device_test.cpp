// A Reconstructor on the app's own Vulkan device (DeviceOptions::external): it scans there, and
// the device outlives it, still the app's to use; missing handles are refused by name.

#include <gtest/gtest.h>
#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "gpu_test_env.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

using test::GpuTest;

// What an app sets up before it creates the scanner: an instance, the device the tests run on
// and one queue of its first compute family.
struct AppDevice {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;

  ExternalDevice handles() const { return {instance, physical, device, queue, family}; }
  ~AppDevice() {
    if (device != VK_NULL_HANDLE) vkDestroyDevice(device, nullptr);
    if (instance != VK_NULL_HANDLE) vkDestroyInstance(instance, nullptr);
  }
};

void make_app_device(int index, AppDevice& app) {
  VkApplicationInfo info{};
  info.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  info.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo instance_info{};
  instance_info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  instance_info.pApplicationInfo = &info;
  ASSERT_EQ(vkCreateInstance(&instance_info, nullptr, &app.instance), VK_SUCCESS);
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(app.instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(app.instance, &count, devices.data());
  ASSERT_LT(static_cast<std::uint32_t>(index), count);
  app.physical = devices[static_cast<std::size_t>(index)];
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(app.physical, &count, families.data());
  while (app.family < count && (families[app.family].queueFlags & VK_QUEUE_COMPUTE_BIT) == 0)
    ++app.family;
  ASSERT_LT(app.family, count);
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{};
  queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue_info.queueFamilyIndex = app.family;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkDeviceCreateInfo device_info{};
  device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  ASSERT_EQ(vkCreateDevice(app.physical, &device_info, nullptr, &app.device), VK_SUCCESS);
  vkGetDeviceQueue(app.device, app.family, 0, &app.queue);
}

TEST_F(GpuTest, TheScannerRunsOnTheAppsDeviceAndLeavesItAlive) {
  AppDevice app;
  make_app_device(context_->info().index, app);
  ASSERT_NE(app.queue, VK_NULL_HANDLE);
  const Intrinsics k = synth::default_intrinsics(160, 120);
  ReconstructorConfig config = preset_config(SensorPreset::kKinect, k, /*with_imu=*/false);
  config.device.external = app.handles();
  {
    auto scanner = Reconstructor::create(config);
    ASSERT_TRUE(scanner.ok()) << scanner.error().describe();
    EXPECT_EQ(scanner->device().name, context_->info().name);
    EXPECT_EQ(scanner->device().index, context_->info().index);
    // Three frames of the synthetic room: the first fused, the next tracked by ICP and fused.
    const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 2);
    const synth::CameraMotion motion(synth::SceneKind::kRoom, 5);
    for (int f = 0; f < 3; ++f) {
      const double t = 2.0 + f / 30.0;
      const DepthImage depth = synth::render_depth(scene, motion.pose_at(t), k, {}, 20 + f);
      auto frame = scanner->track_and_fuse(t, depth);
      ASSERT_TRUE(frame.ok()) << frame.error().describe();
      EXPECT_TRUE(frame->fused) << "frame " << f;
      EXPECT_EQ(frame->icp_ran, f > 0);
    }
    EXPECT_GT(scanner->allocated_blocks(), 0u);
  }
  // The device is still the app's: idle, and it makes and frees a buffer.
  EXPECT_EQ(vkDeviceWaitIdle(app.device), VK_SUCCESS);
  VkBufferCreateInfo buffer_info{};
  buffer_info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  buffer_info.size = 256;
  buffer_info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  EXPECT_EQ(vkCreateBuffer(app.device, &buffer_info, nullptr, &buffer), VK_SUCCESS);
  vkDestroyBuffer(app.device, buffer, nullptr);
}

TEST_F(GpuTest, AnExternalDeviceWithoutItsHandlesIsRefusedByName) {
  AppDevice app;
  make_app_device(context_->info().index, app);
  const Intrinsics k = synth::default_intrinsics(160, 120);
  ReconstructorConfig config = preset_config(SensorPreset::kKinect, k, /*with_imu=*/false);
  for (const std::string missing : {"instance", "physical_device", "device", "queue"}) {
    ExternalDevice e = app.handles();
    if (missing == "instance") e.instance = nullptr;
    if (missing == "physical_device") e.physical_device = nullptr;
    if (missing == "device") e.device = nullptr;
    if (missing == "queue") e.queue = nullptr;
    config.device.external = e;
    auto scanner = Reconstructor::create(config);
    ASSERT_FALSE(scanner.ok()) << missing;
    EXPECT_NE(scanner.error().message.find(missing + " is null"), std::string::npos)
        << scanner.error().message;
  }
  ExternalDevice e = app.handles();
  e.queue_family = 1000;
  config.device.external = e;
  auto scanner = Reconstructor::create(config);
  ASSERT_FALSE(scanner.ok());
  EXPECT_NE(scanner.error().message.find("queue family 1000"), std::string::npos);
}

}  // namespace
}  // namespace imufusion
