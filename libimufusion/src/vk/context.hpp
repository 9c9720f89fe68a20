#pragma once
// The Vulkan instance, the chosen physical device, its logical device and compute queue.
// Shared (std::shared_ptr) by every buffer, pipeline and command sequence made from it, so that
// it outlives them.

#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "imufusion/device.hpp"
#include "imufusion/result.hpp"

namespace imufusion::gpu {

/// Whether buffers can live mapped in device memory: a device-local, host-visible, coherent and
/// cached type on a heap of at least `device_local_bytes` (a CPU device or an integrated GPU).
bool has_unified_memory(const VkPhysicalDeviceMemoryProperties& memory,
                        std::uint64_t device_local_bytes);

class Context {
 public:
  static Result<std::shared_ptr<Context>> create(const DeviceOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkDevice device() const { return device_; }
  VkPhysicalDevice physical_device() const { return physical_device_; }
  VkQueue queue() const { return queue_; }
  std::uint32_t queue_family() const { return queue_family_; }
  const DeviceInfo& info() const { return info_; }
  const VkPhysicalDeviceLimits& limits() const { return limits_; }

  /// True when one memory type is device-local, host-visible and coherent over the whole
  /// device-local heap (CPU devices, integrated GPUs): buffers are then mapped directly.
  bool unified_memory() const { return unified_memory_; }
  /// Nanoseconds per timestamp tick; 0 when the compute queue has no timestamps.
  double timestamp_period_ns() const { return timestamp_period_ns_; }

  /// A memory type index with all `required` flags among `type_bits`, or kOutOfDeviceMemory.
  Result<std::uint32_t> find_memory_type(std::uint32_t type_bits,
                                         VkMemoryPropertyFlags required) const;

  /// vkQueueSubmit under the queue's lock (the queue is shared by every command sequence).
  VkResult submit(const VkSubmitInfo& submit_info, VkFence fence);

  /// Records commands with `record`, submits them and waits (for uploads and downloads).
  Status run_once(const std::function<void(VkCommandBuffer)>& record);

  /// Whether a VK_ERROR_DEVICE_LOST has been seen; every later submission fails fast.
  bool lost() const { return lost_.load(); }
  /// Turns a failing VkResult into an Error, remembering device loss.
  Error fail(VkResult result, const std::string& what);

  /// Validation-layer errors reported since creation (0 when validation is off).
  std::uint32_t validation_error_count() const { return validation_errors_.load(); }
  std::vector<std::string> validation_messages() const;
  bool validation_enabled() const { return messenger_ != VK_NULL_HANDLE; }

 private:
  Context() = default;
  Status init(const DeviceOptions& options);
  Status adopt(const ExternalDevice& external);
  void read_properties();
  static VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(
      VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
      const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);

  bool owns_device_ = true;  // false on an app's device (DeviceOptions::external)
  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_device_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool one_shot_pool_ = VK_NULL_HANDLE;
  std::uint32_t queue_family_ = 0;
  DeviceInfo info_;
  VkPhysicalDeviceLimits limits_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  bool unified_memory_ = false;
  double timestamp_period_ns_ = 0;
  std::atomic<bool> lost_{false};
  std::atomic<std::uint32_t> validation_errors_{0};
  mutable std::mutex messages_mutex_;
  std::vector<std::string> validation_messages_;
  std::mutex queue_mutex_;
};

/// Picks a device index from `devices` by `selector` (index or name substring; empty: the best
/// type, discrete > integrated > virtual > CPU). Pure, for testing without Vulkan.
Result<int> select_device(const std::vector<DeviceInfo>& devices, const std::string& selector);

}  // namespace imufusion::gpu
