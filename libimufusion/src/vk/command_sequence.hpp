#pragma once
// Records a sequence of compute dispatches into one command buffer, with a memory barrier after
// each, GPU timestamps around each, and descriptor sets from a pool reset at every begin().
// submit_and_wait() (or submit(), then wait()) returns the per-kernel GPU times. Work submitted
// later on the same queue sees everything a sequence wrote, waited for or not.

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imufusion/device.hpp"
#include "imufusion/result.hpp"
#include "vk/buffer.hpp"
#include "vk/context.hpp"
#include "vk/pipeline.hpp"

namespace imufusion::gpu {

class CommandSequence {
 public:
  /// Room for up to `max_dispatches` dispatches between begin() and submit_and_wait().
  static Result<CommandSequence> create(std::shared_ptr<Context> context,
                                        std::uint32_t max_dispatches);

  CommandSequence() = default;
  ~CommandSequence();
  CommandSequence(CommandSequence&& other) noexcept;
  CommandSequence& operator=(CommandSequence&& other) noexcept;
  CommandSequence(const CommandSequence&) = delete;
  CommandSequence& operator=(const CommandSequence&) = delete;

  Status begin();
  /// Records one dispatch of `pipeline` over a width x height grid of invocations (rounded up to
  /// whole workgroups), binding `buffers` in order. Errors are kept and returned by submit.
  void dispatch(const ComputePipeline& pipeline, std::initializer_list<const Buffer*> buffers,
                const void* push_constants, std::uint32_t width, std::uint32_t height,
                const std::string& label);
  template <typename Push>
  void dispatch(const ComputePipeline& pipeline, std::initializer_list<const Buffer*> buffers,
                const Push& push, std::uint32_t width, std::uint32_t height,
                const std::string& label) {
    dispatch(pipeline, buffers, static_cast<const void*>(&push), width, height, label);
  }
  /// Records one dispatch whose workgroup counts (VkDispatchIndirectCommand) the GPU reads from
  /// `args` at byte `offset` when it runs: written by an earlier dispatch of this or an earlier
  /// submission.
  template <typename Push>
  void dispatch_indirect(const ComputePipeline& pipeline,
                         std::initializer_list<const Buffer*> buffers, const Push& push,
                         const Buffer& args, VkDeviceSize offset, const std::string& label) {
    record_dispatch(pipeline, buffers, static_cast<const void*>(&push), 0, 0, &args, offset, label);
  }
  /// Records a copy of the first `bytes` of `src` into `dst`, ordered after the dispatches before
  /// it and before those after it; counts as one dispatch (timed, labelled).
  void copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes, const std::string& label);
  /// Records filling `buffer` with the 32-bit `value`, ordered like a dispatch; counts as one.
  void fill(const Buffer& buffer, std::uint32_t value, const std::string& label);
  /// Ends recording, submits, waits for completion, and returns one timing per dispatch.
  Result<std::vector<KernelTiming>> submit_and_wait();
  /// Ends recording and submits without waiting; wait() must follow before the next begin().
  Status submit();
  /// Waits for the submitted sequence and returns one timing per dispatch.
  Result<std::vector<KernelTiming>> wait();
  /// Submitted and not yet waited for.
  bool pending() const { return pending_; }

 private:
  void release();
  void record_dispatch(const ComputePipeline& pipeline,
                       std::initializer_list<const Buffer*> buffers, const void* push_constants,
                       std::uint32_t width, std::uint32_t height, const Buffer* args,
                       VkDeviceSize offset, const std::string& label);
  bool check_room(const std::string& label);
  void record_transfer(const std::string& label, VkAccessFlags access,
                       const std::function<void()>& command);
  void barrier(VkPipelineStageFlags src_stage, VkAccessFlags src_access,
               VkPipelineStageFlags dst_stage, VkAccessFlags dst_access);

  std::shared_ptr<Context> context_;
  std::uint32_t max_dispatches_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkQueryPool queries_ = VK_NULL_HANDLE;
  std::vector<std::string> labels_;
  std::optional<Error> error_;
  bool recording_ = false;
  bool pending_ = false;
};

}  // namespace imufusion::gpu
