#include "vk/command_sequence.hpp"

#include <utility>

namespace imufusion::gpu {
namespace {

constexpr std::uint32_t kMaxBuffersPerDispatch = 12;  // descriptors reserved per dispatch
constexpr std::uint64_t kFenceTimeoutNs = 120ull * 1000 * 1000 * 1000;

}  // namespace

Result<CommandSequence> CommandSequence::create(std::shared_ptr<Context> context,
                                                std::uint32_t max_dispatches) {
  CommandSequence seq;
  seq.context_ = std::move(context);
  seq.max_dispatches_ = max_dispatches;
  Context& ctx = *seq.context_;

  VkCommandPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = ctx.queue_family();
  VkResult result = vkCreateCommandPool(ctx.device(), &pool_info, nullptr, &seq.pool_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateCommandPool");

  VkCommandBufferAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  alloc.commandPool = seq.pool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  result = vkAllocateCommandBuffers(ctx.device(), &alloc, &seq.cmd_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkAllocateCommandBuffers");

  VkFenceCreateInfo fence_info{};
  fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  result = vkCreateFence(ctx.device(), &fence_info, nullptr, &seq.fence_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateFence");

  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                  max_dispatches * kMaxBuffersPerDispatch};
  VkDescriptorPoolCreateInfo dp_info{};
  dp_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  dp_info.maxSets = max_dispatches;
  dp_info.poolSizeCount = 1;
  dp_info.pPoolSizes = &size;
  result = vkCreateDescriptorPool(ctx.device(), &dp_info, nullptr, &seq.descriptor_pool_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateDescriptorPool");

  if (ctx.timestamp_period_ns() > 0) {
    VkQueryPoolCreateInfo q_info{};
    q_info.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    q_info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q_info.queryCount = 2 * max_dispatches;
    result = vkCreateQueryPool(ctx.device(), &q_info, nullptr, &seq.queries_);
    if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateQueryPool");
  }
  return seq;
}

CommandSequence::~CommandSequence() { release(); }

CommandSequence::CommandSequence(CommandSequence&& other) noexcept { *this = std::move(other); }

CommandSequence& CommandSequence::operator=(CommandSequence&& other) noexcept {
  if (this != &other) {
    release();
    context_ = std::move(other.context_);
    max_dispatches_ = other.max_dispatches_;
    pool_ = std::exchange(other.pool_, VK_NULL_HANDLE);
    cmd_ = std::exchange(other.cmd_, VK_NULL_HANDLE);
    fence_ = std::exchange(other.fence_, VK_NULL_HANDLE);
    descriptor_pool_ = std::exchange(other.descriptor_pool_, VK_NULL_HANDLE);
    queries_ = std::exchange(other.queries_, VK_NULL_HANDLE);
    labels_ = std::move(other.labels_);
    error_ = std::move(other.error_);
    recording_ = std::exchange(other.recording_, false);
    pending_ = std::exchange(other.pending_, false);
  }
  return *this;
}

void CommandSequence::release() {
  if (!context_) return;
  VkDevice device = context_->device();
  if (recording_) vkEndCommandBuffer(cmd_);
  // A submitted sequence may still run: its command buffer and descriptors must outlive it.
  if (pending_ && !context_->lost()) vkWaitForFences(device, 1, &fence_, VK_TRUE, kFenceTimeoutNs);
  if (queries_ != VK_NULL_HANDLE) vkDestroyQueryPool(device, queries_, nullptr);
  if (descriptor_pool_ != VK_NULL_HANDLE)
    vkDestroyDescriptorPool(device, descriptor_pool_, nullptr);
  if (fence_ != VK_NULL_HANDLE) vkDestroyFence(device, fence_, nullptr);
  if (pool_ != VK_NULL_HANDLE) vkDestroyCommandPool(device, pool_, nullptr);  // frees cmd_
  queries_ = VK_NULL_HANDLE;
  descriptor_pool_ = VK_NULL_HANDLE;
  fence_ = VK_NULL_HANDLE;
  pool_ = VK_NULL_HANDLE;
  cmd_ = VK_NULL_HANDLE;
  context_.reset();
}

Status CommandSequence::begin() {
  if (!context_) return make_error(ErrorCode::kInternal, "begin() on an empty command sequence");
  Context& ctx = *context_;
  if (ctx.lost())
    return make_error(ErrorCode::kDeviceLost, "device " + ctx.info().name + " was lost");
  if (recording_) return make_error(ErrorCode::kInternal, "begin() while already recording");
  if (pending_) return make_error(ErrorCode::kInternal, "begin() before wait() on the submission");
  error_.reset();
  labels_.clear();
  VkResult result = vkResetDescriptorPool(ctx.device(), descriptor_pool_, 0);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkResetDescriptorPool");
  result = vkResetCommandBuffer(cmd_, 0);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkResetCommandBuffer");
  VkCommandBufferBeginInfo begin_info{};
  begin_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin_info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  result = vkBeginCommandBuffer(cmd_, &begin_info);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkBeginCommandBuffer");
  if (queries_ != VK_NULL_HANDLE) vkCmdResetQueryPool(cmd_, queries_, 0, 2 * max_dispatches_);
  recording_ = true;
  return {};
}

void CommandSequence::dispatch(const ComputePipeline& pipeline,
                               std::initializer_list<const Buffer*> buffers,
                               const void* push_constants, std::uint32_t width,
                               std::uint32_t height, const std::string& label) {
  record_dispatch(pipeline, buffers, push_constants, width, height, nullptr, 0, label);
}

void CommandSequence::record_dispatch(const ComputePipeline& pipeline,
                                      std::initializer_list<const Buffer*> buffers,
                                      const void* push_constants, std::uint32_t width,
                                      std::uint32_t height, const Buffer* args, VkDeviceSize offset,
                                      const std::string& label) {
  if (!check_room(label)) return;
  if (args != nullptr && (!args->valid() || offset % 4 != 0 ||
                          offset + sizeof(VkDispatchIndirectCommand) > args->size())) {
    error_ = make_error(ErrorCode::kInternal, label + ": indirect arguments at byte " +
                                                  std::to_string(offset) + " out of range");
    return;
  }
  const PipelineDesc& desc = pipeline.desc();
  if (buffers.size() != desc.buffer_count || buffers.size() > kMaxBuffersPerDispatch) {
    error_ = make_error(ErrorCode::kInternal, label + ": " + std::to_string(buffers.size()) +
                                                  " buffers bound, shader " + desc.shader +
                                                  " takes " + std::to_string(desc.buffer_count));
    return;
  }
  Context& ctx = *context_;
  VkDescriptorSetLayout set_layout = pipeline.set_layout();
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = descriptor_pool_;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &set_layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  const VkResult result = vkAllocateDescriptorSets(ctx.device(), &alloc, &set);
  if (result != VK_SUCCESS) {
    error_ = ctx.fail(result, "vkAllocateDescriptorSets for " + label);
    return;
  }
  std::vector<VkDescriptorBufferInfo> infos;
  std::vector<VkWriteDescriptorSet> writes;
  infos.reserve(buffers.size());
  for (const Buffer* buffer : buffers) {
    if (buffer == nullptr || !buffer->valid()) {
      error_ = make_error(ErrorCode::kInternal, label + ": an empty buffer is bound");
      return;
    }
    infos.push_back({buffer->handle(), 0, VK_WHOLE_SIZE});
  }
  for (std::uint32_t i = 0; i < infos.size(); ++i) {
    VkWriteDescriptorSet write{};
    write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    write.dstSet = set;
    write.dstBinding = i;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    write.pBufferInfo = &infos[i];
    writes.push_back(write);
  }
  vkUpdateDescriptorSets(ctx.device(), static_cast<std::uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);

  const auto index = static_cast<std::uint32_t>(labels_.size());
  if (queries_ != VK_NULL_HANDLE)
    vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 2 * index);
  vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline());
  vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.layout(), 0, 1, &set, 0,
                          nullptr);
  if (desc.push_constant_bytes > 0) {
    vkCmdPushConstants(cmd_, pipeline.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0,
                       desc.push_constant_bytes, push_constants);
  }
  const std::uint32_t groups_x = (width + desc.local_size_x - 1) / desc.local_size_x;
  const std::uint32_t groups_y = (height + desc.local_size_y - 1) / desc.local_size_y;
  if (args != nullptr)
    vkCmdDispatchIndirect(cmd_, args->handle(), offset);
  else if (groups_x > 0 && groups_y > 0)
    vkCmdDispatch(cmd_, groups_x, groups_y, 1);
  if (queries_ != VK_NULL_HANDLE)
    vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 2 * index + 1);

  // The next dispatch may read what this one wrote, as data or as its indirect arguments.
  barrier(
      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
  labels_.push_back(label);
}

void CommandSequence::copy(const Buffer& src, const Buffer& dst, VkDeviceSize bytes,
                           const std::string& label) {
  if (!check_room(label)) return;
  if (!src.valid() || !dst.valid() || bytes > src.size() || bytes > dst.size()) {
    error_ =
        make_error(ErrorCode::kInternal,
                   label + ": copy of " + std::to_string(bytes) + " bytes between buffers of " +
                       std::to_string(src.size()) + " and " + std::to_string(dst.size()));
    return;
  }
  record_transfer(label, VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, [&] {
    const VkBufferCopy region{0, 0, bytes};
    if (bytes > 0) vkCmdCopyBuffer(cmd_, src.handle(), dst.handle(), 1, &region);
  });
}

void CommandSequence::fill(const Buffer& buffer, std::uint32_t value, const std::string& label) {
  if (!check_room(label)) return;
  if (!buffer.valid()) {
    error_ = make_error(ErrorCode::kInternal, label + ": fill of an empty buffer");
    return;
  }
  record_transfer(label, VK_ACCESS_TRANSFER_WRITE_BIT,
                  [&] { vkCmdFillBuffer(cmd_, buffer.handle(), 0, VK_WHOLE_SIZE, value); });
}

// A transfer command between the dispatches, timed and labelled like one: after the shader
// writes before it (`access`: what the command does), its writes visible to the shaders and
// indirect dispatches after it.
void CommandSequence::record_transfer(const std::string& label, VkAccessFlags access,
                                      const std::function<void()>& command) {
  const auto index = static_cast<std::uint32_t>(labels_.size());
  if (queries_ != VK_NULL_HANDLE)
    vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 2 * index);
  barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT,
          VK_PIPELINE_STAGE_TRANSFER_BIT, access);
  command();
  barrier(
      VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
      VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
  if (queries_ != VK_NULL_HANDLE)
    vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, 2 * index + 1);
  labels_.push_back(label);
}

bool CommandSequence::check_room(const std::string& label) {
  if (error_) return false;
  if (!recording_) {
    error_ = make_error(ErrorCode::kInternal, "dispatch of " + label + " outside begin()/submit");
    return false;
  }
  if (labels_.size() >= max_dispatches_) {
    error_ = make_error(ErrorCode::kInternal, "more than " + std::to_string(max_dispatches_) +
                                                  " dispatches in one command sequence");
    return false;
  }
  return true;
}

void CommandSequence::barrier(VkPipelineStageFlags src_stage, VkAccessFlags src_access,
                              VkPipelineStageFlags dst_stage, VkAccessFlags dst_access) {
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = src_access;
  barrier.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd_, src_stage, dst_stage, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

Result<std::vector<KernelTiming>> CommandSequence::submit_and_wait() {
  IMUFUSION_RETURN_IF_ERROR(submit());
  return wait();
}

Status CommandSequence::submit() {
  if (!recording_) return make_error(ErrorCode::kInternal, "submit without begin()");
  Context& ctx = *context_;
  // Results written by the shaders and copies become visible to host reads, to transfers and to
  // the dispatches of later submissions on the queue.
  barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
          VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
          VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
              VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
          VK_ACCESS_HOST_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_SHADER_READ_BIT |
              VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT);
  VkResult result = vkEndCommandBuffer(cmd_);
  recording_ = false;
  if (error_) return *error_;
  if (result != VK_SUCCESS) return ctx.fail(result, "vkEndCommandBuffer");

  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd_;
  result = vkResetFences(ctx.device(), 1, &fence_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkResetFences");
  result = ctx.submit(submit, fence_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkQueueSubmit");
  pending_ = true;
  return {};
}

Result<std::vector<KernelTiming>> CommandSequence::wait() {
  if (!pending_) return make_error(ErrorCode::kInternal, "wait() without submit()");
  Context& ctx = *context_;
  VkResult result = vkWaitForFences(ctx.device(), 1, &fence_, VK_TRUE, kFenceTimeoutNs);
  pending_ = false;
  if (result != VK_SUCCESS) return ctx.fail(result, "waiting for the GPU (vkWaitForFences)");

  std::vector<KernelTiming> timings;
  timings.reserve(labels_.size());
  std::vector<std::uint64_t> stamps(2 * labels_.size());
  bool have_stamps = false;
  if (queries_ != VK_NULL_HANDLE && !labels_.empty()) {
    result = vkGetQueryPoolResults(
        ctx.device(), queries_, 0, static_cast<std::uint32_t>(stamps.size()),
        stamps.size() * sizeof(std::uint64_t), stamps.data(), sizeof(std::uint64_t),
        VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
    if (result != VK_SUCCESS) return ctx.fail(result, "vkGetQueryPoolResults");
    have_stamps = true;
  }
  for (std::size_t i = 0; i < labels_.size(); ++i) {
    KernelTiming t;
    t.kernel = labels_[i];
    if (have_stamps) {
      t.gpu_ms =
          static_cast<double>(stamps[2 * i + 1] - stamps[2 * i]) * ctx.timestamp_period_ns() * 1e-6;
    }
    timings.push_back(std::move(t));
  }
  return timings;
}

}  // namespace imufusion::gpu
