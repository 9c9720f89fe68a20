#pragma once
// Vulkan compute devices as a user sees them: listing and choosing one. No Vulkan types here.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "imufusion/result.hpp"

namespace imufusion {

enum class DeviceType { kDiscreteGpu, kIntegratedGpu, kVirtualGpu, kCpu, kOther };

const char* to_string(DeviceType type);

struct DeviceInfo {
  int index = -1;    // position in the Vulkan physical-device list
  std::string name;  // e.g. "NVIDIA H100", "llvmpipe (LLVM 15.0.6, 256 bits)"
  DeviceType type = DeviceType::kOther;
  std::string driver;                    // driver name and info, e.g. "llvmpipe Mesa 22.3.6"
  std::uint32_t api_version = 0;         // VK_MAKE_API_VERSION encoding
  std::uint64_t device_local_bytes = 0;  // size of the largest device-local heap
  bool timestamps = false;               // whether per-kernel GPU timings are available
  std::uint32_t subgroup_size = 0;       // invocations per subgroup (Vulkan 1.1)
  bool subgroup_arithmetic = false;      // compute shaders may add across a subgroup
};

/// A Vulkan device the app already has, for the library to run on instead of creating its own.
/// Each handle is the app's Vulkan handle cast to void* (VkInstance, VkPhysicalDevice, VkDevice
/// and VkQueue are pointers): the library creates its buffers, pipelines and command pools on the
/// device and destroys only those; the app keeps the device alive until every object made with
/// it is gone, and does not submit to `queue` from another thread while the library runs (give
/// the library a queue of its own where the family has several). Vulkan 1.1; the queue's family
/// must support compute.
struct ExternalDevice {
  void* instance = nullptr;         // VkInstance the physical device came from
  void* physical_device = nullptr;  // VkPhysicalDevice
  void* device = nullptr;           // VkDevice, created with `queue_family` among its queues
  void* queue = nullptr;            // VkQueue of queue_family
  std::uint32_t queue_family = 0;
};

/// How to pick and set up a device.
struct DeviceOptions {
  /// Empty: the IMUFUSION_DEVICE environment variable if set, else the first discrete GPU, then
  /// integrated, virtual, then CPU (lavapipe). Otherwise a device index ("1") or a case-insensitive
  /// substring of the device name ("llvmpipe", "nvidia").
  std::string selector;
  /// Enable the Khronos validation layer (also when IMUFUSION_VALIDATION=1). Validation errors are
  /// counted by the context; tests fail on any.
  bool validation = false;
  /// Run on the app's own device (selector and validation are then the app's business); empty:
  /// the library creates its own instance and device.
  std::optional<ExternalDevice> external;
};

/// The GPU time of one kernel dispatch, from timestamp queries (milliseconds). Where the device
/// has no timestamps, `gpu_ms` is negative.
struct KernelTiming {
  std::string kernel;  // e.g. "bilateral[0]": shader name and pyramid level
  double gpu_ms = -1;
};

/// The Vulkan devices of this machine, in Vulkan's order. kNoDevice when there is no Vulkan loader,
/// no ICD, or no device with a compute queue.
Result<std::vector<DeviceInfo>> list_devices();

}  // namespace imufusion
