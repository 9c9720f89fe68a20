#include "vk/buffer.hpp"

#include <cstring>
#include <string>
#include <utility>

#include "vk/vk_error.hpp"

namespace imufusion::gpu {

namespace {

// A mapped buffer is read by the host (staging, unified memory): host-cached memory first (the
// unified type itself, or system memory on a discrete GPU), then any coherent host-visible type.
// Otherwise device-local memory.
Result<std::uint32_t> memory_type(const Context& ctx, std::uint32_t type_bits, bool mapped) {
  if (!mapped) return ctx.find_memory_type(type_bits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  const VkMemoryPropertyFlags host =
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  if (ctx.unified_memory()) {
    auto unified = ctx.find_memory_type(
        type_bits, host | VK_MEMORY_PROPERTY_HOST_CACHED_BIT | VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (unified) return unified;
  }
  auto cached = ctx.find_memory_type(type_bits, host | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
  if (cached) return cached;
  return ctx.find_memory_type(type_bits, host);
}

}  // namespace

Result<Buffer> Buffer::create(std::shared_ptr<Context> context, VkDeviceSize bytes,
                              bool host_visible) {
  if (bytes == 0) return make_error(ErrorCode::kInvalidArgument, "buffer of 0 bytes");
  Buffer buffer;
  buffer.context_ = std::move(context);
  Context& ctx = *buffer.context_;
  buffer.size_ = (bytes + 3) / 4 * 4;
  const bool mapped = host_visible || ctx.unified_memory();

  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = buffer.size_;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
               VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkResult result = vkCreateBuffer(ctx.device(), &info, nullptr, &buffer.buffer_);
  if (result != VK_SUCCESS)
    return ctx.fail(result, "vkCreateBuffer (" + std::to_string(bytes) + " bytes)");

  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(ctx.device(), buffer.buffer_, &req);
  Result<std::uint32_t> type = memory_type(ctx, req.memoryTypeBits, mapped);
  if (!type) return type.error();

  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = *type;
  result = vkAllocateMemory(ctx.device(), &alloc, nullptr, &buffer.memory_);
  if (result != VK_SUCCESS)
    return ctx.fail(result, "vkAllocateMemory (" + std::to_string(req.size) + " bytes)");
  result = vkBindBufferMemory(ctx.device(), buffer.buffer_, buffer.memory_, 0);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkBindBufferMemory");
  if (mapped) {
    result = vkMapMemory(ctx.device(), buffer.memory_, 0, VK_WHOLE_SIZE, 0, &buffer.mapped_);
    if (result != VK_SUCCESS) return ctx.fail(result, "vkMapMemory");
  }
  return buffer;
}

Buffer::~Buffer() { release(); }

Buffer::Buffer(Buffer&& other) noexcept { *this = std::move(other); }

Buffer& Buffer::operator=(Buffer&& other) noexcept {
  if (this != &other) {
    release();
    context_ = std::move(other.context_);
    buffer_ = std::exchange(other.buffer_, VK_NULL_HANDLE);
    memory_ = std::exchange(other.memory_, VK_NULL_HANDLE);
    size_ = std::exchange(other.size_, 0);
    mapped_ = std::exchange(other.mapped_, nullptr);
    staging_ = std::move(other.staging_);
  }
  return *this;
}

void Buffer::release() {
  staging_.reset();
  if (!context_) return;
  VkDevice device = context_->device();
  if (mapped_ != nullptr) vkUnmapMemory(device, memory_);
  if (buffer_ != VK_NULL_HANDLE) vkDestroyBuffer(device, buffer_, nullptr);
  if (memory_ != VK_NULL_HANDLE) vkFreeMemory(device, memory_, nullptr);
  mapped_ = nullptr;
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  context_.reset();
}

Status Buffer::check_range(VkDeviceSize bytes, VkDeviceSize offset) const {
  if (buffer_ == VK_NULL_HANDLE) return make_error(ErrorCode::kInternal, "use of an empty buffer");
  if (offset + bytes > size_) {
    return make_error(ErrorCode::kInvalidArgument,
                      "transfer of " + std::to_string(bytes) + " bytes at " +
                          std::to_string(offset) + " exceeds a buffer of " + std::to_string(size_));
  }
  if (context_->lost()) return make_error(ErrorCode::kDeviceLost, "the device was lost earlier");
  return {};
}

Status Buffer::upload(const void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  IMUFUSION_RETURN_IF_ERROR(check_range(bytes, offset));
  if (bytes == 0) return {};
  if (mapped_ != nullptr) {
    std::memcpy(static_cast<char*>(mapped_) + offset, data, bytes);
    return {};
  }
  std::unique_ptr<Buffer> temporary;
  auto staging = this->staging(bytes, temporary);
  if (!staging) return staging.error();
  IMUFUSION_RETURN_IF_ERROR((*staging)->upload(data, bytes));
  const VkBufferCopy region{0, offset, bytes};
  const VkBuffer src = (*staging)->handle();
  return context_->run_once(
      [&](VkCommandBuffer cmd) { vkCmdCopyBuffer(cmd, src, buffer_, 1, &region); });
}

Status Buffer::download(void* data, VkDeviceSize bytes, VkDeviceSize offset) const {
  IMUFUSION_RETURN_IF_ERROR(check_range(bytes, offset));
  if (bytes == 0) return {};
  if (mapped_ != nullptr) {
    std::memcpy(data, static_cast<const char*>(mapped_) + offset, bytes);
    return {};
  }
  std::unique_ptr<Buffer> temporary;
  auto staging = this->staging(bytes, temporary);
  if (!staging) return staging.error();
  const VkBufferCopy region{offset, 0, bytes};
  const VkBuffer dst = (*staging)->handle();
  IMUFUSION_RETURN_IF_ERROR(context_->run_once(
      [&](VkCommandBuffer cmd) { vkCmdCopyBuffer(cmd, buffer_, dst, 1, &region); }));
  return (*staging)->download(data, bytes);
}

Result<Buffer*> Buffer::staging(VkDeviceSize bytes, std::unique_ptr<Buffer>& temporary) const {
  if (staging_ && staging_->size() >= bytes) return staging_.get();
  auto created = Buffer::create(context_, bytes, true);
  if (!created) return created.error();
  auto& keep = bytes <= kKeptStagingBytes ? staging_ : temporary;
  keep = std::make_unique<Buffer>(std::move(*created));
  return keep.get();
}

Status Buffer::clear() {
  IMUFUSION_RETURN_IF_ERROR(check_range(size_, 0));
  if (mapped_ != nullptr) {
    std::memset(mapped_, 0, size_);
    return {};
  }
  return context_->run_once(
      [&](VkCommandBuffer cmd) { vkCmdFillBuffer(cmd, buffer_, 0, size_, 0); });
}

}  // namespace imufusion::gpu
