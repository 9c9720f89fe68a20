#pragma once
// A storage buffer that owns its VkBuffer and memory. On unified-memory devices it lives in
// device-local, host-visible memory and is mapped; elsewhere it is device-local and transfers go
// through a host-cached staging buffer, kept for the next transfer up to kKeptStagingBytes.

#include <vulkan/vulkan.h>

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "imufusion/result.hpp"
#include "vk/context.hpp"

namespace imufusion::gpu {

class Buffer {
 public:
  /// A storage buffer of `bytes` (rounded up to 4). Host-visible memory is chosen when
  /// `host_visible` is set or the device has unified memory.
  static Result<Buffer> create(std::shared_ptr<Context> context, VkDeviceSize bytes,
                               bool host_visible = false);

  Buffer() = default;
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  bool valid() const { return buffer_ != VK_NULL_HANDLE; }
  /// The buffer's memory as the host sees it, or nullptr when it is not host-visible.
  void* mapped() const { return mapped_; }

  Status upload(const void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
  Status download(void* data, VkDeviceSize bytes, VkDeviceSize offset = 0) const;
  /// Fills with zero bytes.
  Status clear();

  template <typename T>
  Status upload(std::span<const T> values) {
    return upload(values.data(), values.size_bytes());
  }
  template <typename T>
  Result<std::vector<T>> download_as(std::size_t count) const {
    std::vector<T> values(count);
    IMUFUSION_RETURN_IF_ERROR(download(values.data(), count * sizeof(T)));
    return values;
  }

 private:
  void release();
  Status check_range(VkDeviceSize bytes, VkDeviceSize offset) const;
  /// A host-visible buffer of at least `bytes`: the kept one, or a new one (kept when small).
  Result<Buffer*> staging(VkDeviceSize bytes, std::unique_ptr<Buffer>& temporary) const;

  std::shared_ptr<Context> context_;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
  mutable std::unique_ptr<Buffer> staging_;
};

/// Staging buffers up to this size (bytes) are kept with their buffer for the next transfer.
inline constexpr VkDeviceSize kKeptStagingBytes = VkDeviceSize{32} << 20;

}  // namespace imufusion::gpu
