#include "vk/context.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "vk/vk_error.hpp"

namespace imufusion {

const char* to_string(DeviceType type) {
  switch (type) {
    case DeviceType::kDiscreteGpu:
      return "discrete GPU";
    case DeviceType::kIntegratedGpu:
      return "integrated GPU";
    case DeviceType::kVirtualGpu:
      return "virtual GPU";
    case DeviceType::kCpu:
      return "CPU";
    case DeviceType::kOther:
      return "other";
  }
  return "other";
}

namespace gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr std::uint64_t kFenceTimeoutNs = 60ull * 1000 * 1000 * 1000;  // a minute: lavapipe is slow

DeviceType to_device_type(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return DeviceType::kDiscreteGpu;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return DeviceType::kIntegratedGpu;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return DeviceType::kVirtualGpu;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return DeviceType::kCpu;
    default:
      return DeviceType::kOther;
  }
}

int type_rank(DeviceType type) {
  switch (type) {
    case DeviceType::kDiscreteGpu:
      return 0;
    case DeviceType::kIntegratedGpu:
      return 1;
    case DeviceType::kVirtualGpu:
      return 2;
    case DeviceType::kCpu:
      return 3;
    case DeviceType::kOther:
      return 4;
  }
  return 4;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool env_flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' && std::strcmp(value, "0") != 0;
}

bool layer_available(const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkLayerProperties> layers(count);
  if (vkEnumerateInstanceLayerProperties(&count, layers.data()) != VK_SUCCESS) return false;
  return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& l) {
    return std::strcmp(l.layerName, name) == 0;
  });
}

bool instance_extension_available(const char* name) {
  std::uint32_t count = 0;
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> exts(count);
  if (vkEnumerateInstanceExtensionProperties(nullptr, &count, exts.data()) != VK_SUCCESS)
    return false;
  return std::any_of(exts.begin(), exts.end(), [&](const VkExtensionProperties& e) {
    return std::strcmp(e.extensionName, name) == 0;
  });
}

// The first queue family with compute, preferring one without graphics (a dedicated compute queue).
int compute_queue_family(VkPhysicalDevice physical) {
  std::uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
  int best = -1;
  for (std::uint32_t i = 0; i < count; ++i) {
    if ((families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) == 0) continue;
    if (best < 0 || (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) == 0)
      best = static_cast<int>(i);
    if ((families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) == 0) break;
  }
  return best;
}

DeviceInfo describe(VkPhysicalDevice physical, int index) {
  VkPhysicalDeviceDriverProperties driver{};
  driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
  VkPhysicalDeviceSubgroupProperties subgroup{};
  subgroup.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
  driver.pNext = &subgroup;
  VkPhysicalDeviceProperties2 props{};
  props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  props.pNext = &driver;
  vkGetPhysicalDeviceProperties2(physical, &props);
  VkPhysicalDeviceMemoryProperties memory{};
  vkGetPhysicalDeviceMemoryProperties(physical, &memory);

  DeviceInfo info;
  info.index = index;
  info.name = props.properties.deviceName;
  info.type = to_device_type(props.properties.deviceType);
  info.driver = std::string(driver.driverName) + " " + driver.driverInfo;
  info.api_version = props.properties.apiVersion;
  info.subgroup_size = subgroup.subgroupSize;
  constexpr VkSubgroupFeatureFlags kArithmetic =
      VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  info.subgroup_arithmetic = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0 &&
                             (subgroup.supportedOperations & kArithmetic) == kArithmetic;
  for (std::uint32_t h = 0; h < memory.memoryHeapCount; ++h) {
    if (memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      info.device_local_bytes =
          std::max<std::uint64_t>(info.device_local_bytes, memory.memoryHeaps[h].size);
  }
  const int family = compute_queue_family(physical);
  if (family >= 0 && props.properties.limits.timestampPeriod > 0) {
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
    info.timestamps = families[static_cast<std::size_t>(family)].timestampValidBits > 0;
  }
  return info;
}

Result<VkInstance> make_instance(bool validation, bool debug_utils) {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "imufusion";
  app.pEngineName = "imufusion";
  app.apiVersion = VK_API_VERSION_1_1;
  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (validation) layers.push_back(kValidationLayer);
  if (debug_utils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  VkInstanceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  info.pApplicationInfo = &app;
  info.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  VkInstance instance = VK_NULL_HANDLE;
  const VkResult result = vkCreateInstance(&info, nullptr, &instance);
  if (result != VK_SUCCESS) {
    Error error = vk_error(result,
                           "vkCreateInstance (is a Vulkan driver installed? Debian: "
                           "mesa-vulkan-drivers)");
    error.code = ErrorCode::kNoDevice;
    return error;
  }
  return instance;
}

Result<std::vector<VkPhysicalDevice>> physical_devices(VkInstance instance) {
  std::uint32_t count = 0;
  IMUFUSION_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr),
                     "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(count);
  IMUFUSION_VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, devices.data()),
                     "vkEnumeratePhysicalDevices");
  devices.resize(count);
  return devices;
}

}  // namespace

Result<int> select_device(const std::vector<DeviceInfo>& devices, const std::string& selector) {
  if (devices.empty()) {
    return make_error(ErrorCode::kNoDevice,
                      "no Vulkan device with a compute queue (install mesa-vulkan-drivers for the "
                      "CPU device lavapipe)");
  }
  auto listing = [&] {
    std::string text;
    for (const DeviceInfo& d : devices)
      text += "\n  [" + std::to_string(d.index) + "] " + d.name + " (" + to_string(d.type) + ")";
    return text;
  };
  if (selector.empty()) {
    const auto best = std::min_element(devices.begin(), devices.end(),
                                       [](const DeviceInfo& a, const DeviceInfo& b) {
                                         return type_rank(a.type) < type_rank(b.type);
                                       });
    return best->index;
  }
  const bool numeric = std::all_of(selector.begin(), selector.end(),
                                   [](unsigned char c) { return std::isdigit(c) != 0; });
  for (const DeviceInfo& d : devices) {
    if (numeric ? std::to_string(d.index) == selector
                : lower(d.name).find(lower(selector)) != std::string::npos)
      return d.index;
  }
  return make_error(ErrorCode::kNoDevice,
                    "no Vulkan device matches '" + selector + "'; available:" + listing());
}

Result<std::vector<DeviceInfo>> list_devices_of(VkInstance instance) {
  auto devices = physical_devices(instance);
  if (!devices) return devices.error();
  std::vector<DeviceInfo> infos;
  for (std::size_t i = 0; i < devices->size(); ++i) {
    if (compute_queue_family((*devices)[i]) < 0) continue;
    infos.push_back(describe((*devices)[i], static_cast<int>(i)));
  }
  return infos;
}

namespace {

// Whether to run with the validation layer: asked for (options.validation or
// IMUFUSION_VALIDATION) and installed. Asked for but missing: a warning on stderr.
bool use_validation(const DeviceOptions& options) {
  const bool want_validation = options.validation || env_flag("IMUFUSION_VALIDATION");
  const bool validation = want_validation && layer_available(kValidationLayer);
  if (want_validation && !validation) {
    std::cerr << "imufusion: validation requested but " << kValidationLayer
              << " is not installed (Debian: vulkan-validationlayers); running without it\n";
  }
  return validation;
}

// A messenger passing validation warnings and errors to `callback` with `user`; left null when
// the instance lacks vkCreateDebugUtilsMessengerEXT.
Status create_messenger(VkInstance instance, PFN_vkDebugUtilsMessengerCallbackEXT callback,
                        void* user, VkDebugUtilsMessengerEXT& messenger) {
  VkDebugUtilsMessengerCreateInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  info.pfnUserCallback = callback;
  info.pUserData = user;
  auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
      vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
  if (create != nullptr) {
    IMUFUSION_VK_CHECK(create(instance, &info, nullptr, &messenger),
                       "vkCreateDebugUtilsMessengerEXT");
  }
  return {};
}

// The index of the device to use: by options.selector, else by IMUFUSION_DEVICE, else the best
// type (select_device).
Result<int> chosen_device(VkInstance instance, const DeviceOptions& options) {
  auto infos = list_devices_of(instance);
  if (!infos) return infos.error();
  std::string selector = options.selector;
  if (selector.empty()) {
    if (const char* env = std::getenv("IMUFUSION_DEVICE")) selector = env;
  }
  return select_device(*infos, selector);
}

// The logical device with one queue of `family`; `name` (the device's) goes into errors.
Status create_device(VkPhysicalDevice physical, std::uint32_t family, const std::string& name,
                     VkDevice& device) {
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{};
  queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue_info.queueFamilyIndex = family;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkDeviceCreateInfo device_info{};
  device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  IMUFUSION_VK_CHECK(vkCreateDevice(physical, &device_info, nullptr, &device),
                     "vkCreateDevice on " + name);
  return {};
}

// The pool of the one-shot command buffers (run_once): transient, on the queue's family.
Status create_one_shot_pool(VkDevice device, std::uint32_t family, VkCommandPool& pool) {
  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pool_info.queueFamilyIndex = family;
  IMUFUSION_VK_CHECK(vkCreateCommandPool(device, &pool_info, nullptr, &pool),
                     "vkCreateCommandPool");
  return {};
}

}  // namespace

// A discrete GPU's host-visible device memory (resizable BAR) is uncached: host reads of it cross
// the bus slowly (bench/README.md, the H200), so it does not count as unified.
bool has_unified_memory(const VkPhysicalDeviceMemoryProperties& memory,
                        std::uint64_t device_local_bytes) {
  bool unified = false;
  for (std::uint32_t t = 0; t < memory.memoryTypeCount; ++t) {
    const VkMemoryPropertyFlags want =
        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
        VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    const VkMemoryType& type = memory.memoryTypes[t];
    if ((type.propertyFlags & want) == want &&
        memory.memoryHeaps[type.heapIndex].size >= device_local_bytes) {
      unified = true;
    }
  }
  return unified;
}

Result<std::shared_ptr<Context>> Context::create(const DeviceOptions& options) {
  std::shared_ptr<Context> context(new Context());
  IMUFUSION_RETURN_IF_ERROR(context->init(options));
  return context;
}

Status Context::init(const DeviceOptions& options) {
  if (options.external) return adopt(*options.external);
  const bool validation = use_validation(options);
  const bool debug_utils =
      validation && instance_extension_available(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  auto instance = make_instance(validation, debug_utils);
  if (!instance) return instance.error();
  instance_ = *instance;
  if (debug_utils) {
    IMUFUSION_RETURN_IF_ERROR(
        create_messenger(instance_, &Context::on_validation_message, this, messenger_));
  }

  auto chosen = chosen_device(instance_, options);
  if (!chosen) return chosen.error();
  auto devices = physical_devices(instance_);
  if (!devices) return devices.error();
  physical_device_ = (*devices)[static_cast<std::size_t>(*chosen)];
  info_ = describe(physical_device_, *chosen);
  queue_family_ = static_cast<std::uint32_t>(compute_queue_family(physical_device_));
  read_properties();
  IMUFUSION_RETURN_IF_ERROR(create_device(physical_device_, queue_family_, info_.name, device_));
  vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
  return create_one_shot_pool(device_, queue_family_, one_shot_pool_);
}

// Limits, timestamps and memory of the chosen physical device and queue family.
void Context::read_properties() {
  VkPhysicalDeviceProperties props{};
  vkGetPhysicalDeviceProperties(physical_device_, &props);
  limits_ = props.limits;
  std::uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &count, families.data());
  info_.timestamps = queue_family_ < count && families[queue_family_].timestampValidBits > 0 &&
                     props.limits.timestampPeriod > 0;
  timestamp_period_ns_ = info_.timestamps ? props.limits.timestampPeriod : 0.0;
  vkGetPhysicalDeviceMemoryProperties(physical_device_, &memory_);
  unified_memory_ = has_unified_memory(memory_, info_.device_local_bytes);
}

// The app's device (DeviceOptions::external): checked, described, never destroyed here.
Status Context::adopt(const ExternalDevice& external) {
  const auto missing = [](const char* what) {
    return make_error(ErrorCode::kInvalidArgument,
                      std::string("DeviceOptions::external: ") + what + " is null");
  };
  if (external.instance == nullptr) return missing("instance");
  if (external.physical_device == nullptr) return missing("physical_device");
  if (external.device == nullptr) return missing("device");
  if (external.queue == nullptr) return missing("queue");
  owns_device_ = false;
  physical_device_ = static_cast<VkPhysicalDevice>(external.physical_device);
  std::uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_device_, &count, families.data());
  if (external.queue_family >= count ||
      (families[external.queue_family].queueFlags & VK_QUEUE_COMPUTE_BIT) == 0) {
    return make_error(ErrorCode::kInvalidArgument, "DeviceOptions::external: queue family " +
                                                       std::to_string(external.queue_family) +
                                                       " of " + std::to_string(count) +
                                                       " has no compute");
  }
  // Its position among the app's instance's devices, as list_devices() numbers them.
  int index = -1;
  auto devices = physical_devices(static_cast<VkInstance>(external.instance));
  if (devices) {
    for (std::size_t i = 0; i < devices->size(); ++i)
      if ((*devices)[i] == physical_device_) index = static_cast<int>(i);
  }
  info_ = describe(physical_device_, index);
  queue_family_ = external.queue_family;
  read_properties();
  device_ = static_cast<VkDevice>(external.device);
  queue_ = static_cast<VkQueue>(external.queue);
  return create_one_shot_pool(device_, queue_family_, one_shot_pool_);
}

Context::~Context() {
  if (!owns_device_) {  // the app's device: only what the library made on it goes
    if (queue_ != VK_NULL_HANDLE) vkQueueWaitIdle(queue_);
    if (one_shot_pool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device_, one_shot_pool_, nullptr);
    return;
  }
  if (device_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(device_);
    if (one_shot_pool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device_, one_shot_pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_ != VK_NULL_HANDLE) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy != nullptr) destroy(instance_, messenger_, nullptr);
  }
  if (instance_ != VK_NULL_HANDLE) vkDestroyInstance(instance_, nullptr);
}

Result<std::uint32_t> Context::find_memory_type(std::uint32_t type_bits,
                                                VkMemoryPropertyFlags required) const {
  for (std::uint32_t t = 0; t < memory_.memoryTypeCount; ++t) {
    if ((type_bits & (1u << t)) && (memory_.memoryTypes[t].propertyFlags & required) == required)
      return t;
  }
  return make_error(ErrorCode::kOutOfDeviceMemory,
                    "no memory type with the required properties on " + info_.name);
}

Error Context::fail(VkResult result, const std::string& what) {
  if (result == VK_ERROR_DEVICE_LOST) lost_ = true;
  return vk_error(result, what);
}

VkResult Context::submit(const VkSubmitInfo& submit_info, VkFence fence) {
  if (lost_) return VK_ERROR_DEVICE_LOST;
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return vkQueueSubmit(queue_, 1, &submit_info, fence);
}

Status Context::run_once(const std::function<void(VkCommandBuffer)>& record) {
  if (lost_)
    return make_error(ErrorCode::kDeviceLost, "device " + info_.name + " was lost earlier");
  VkCommandBufferAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  alloc.commandPool = one_shot_pool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  std::unique_lock<std::mutex> lock(queue_mutex_);  // the pool is externally synchronized too
  VkResult result = vkAllocateCommandBuffers(device_, &alloc, &cmd);
  if (result != VK_SUCCESS) return fail(result, "vkAllocateCommandBuffers");
  VkFence fence = VK_NULL_HANDLE;
  VkFenceCreateInfo fence_info{};
  fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  result = vkCreateFence(device_, &fence_info, nullptr, &fence);
  if (result == VK_SUCCESS) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cmd, &begin);
    record(cmd);
    result = vkEndCommandBuffer(cmd);
    if (result == VK_SUCCESS) {
      VkSubmitInfo submit_info{};
      submit_info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
      submit_info.commandBufferCount = 1;
      submit_info.pCommandBuffers = &cmd;
      result = vkQueueSubmit(queue_, 1, &submit_info, fence);
      if (result == VK_SUCCESS)
        result = vkWaitForFences(device_, 1, &fence, VK_TRUE, kFenceTimeoutNs);
    }
    vkDestroyFence(device_, fence, nullptr);
  }
  vkFreeCommandBuffers(device_, one_shot_pool_, 1, &cmd);
  if (result != VK_SUCCESS) return fail(result, "transfer on " + info_.name);
  return {};
}

std::vector<std::string> Context::validation_messages() const {
  std::lock_guard<std::mutex> lock(messages_mutex_);
  return validation_messages_;
}

VKAPI_ATTR VkBool32 VKAPI_CALL Context::on_validation_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT /*types*/,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* self = static_cast<Context*>(user);
  const std::string text = data != nullptr && data->pMessage != nullptr ? data->pMessage : "";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    self->validation_errors_++;
    std::lock_guard<std::mutex> lock(self->messages_mutex_);
    self->validation_messages_.push_back(text);
  }
  std::cerr << "[vulkan validation] " << text << "\n";
  return VK_FALSE;
}

}  // namespace gpu

Result<std::vector<DeviceInfo>> list_devices() {
  auto instance = gpu::make_instance(false, false);
  if (!instance) return instance.error();
  auto infos = gpu::list_devices_of(*instance);
  vkDestroyInstance(*instance, nullptr);
  return infos;
}

}  // namespace imufusion
