#include "vk/pipeline.hpp"

#include <array>
#include <utility>
#include <vector>

namespace imufusion::gpu {

Result<ComputePipeline> ComputePipeline::create(std::shared_ptr<Context> context,
                                                const PipelineDesc& desc) {
  const std::span<const std::uint32_t> spirv = embedded_spirv(desc.shader);
  if (spirv.empty()) {
    return make_error(ErrorCode::kInternal, "no embedded shader named '" + desc.shader + "'");
  }
  if (desc.local_size_x * desc.local_size_y > context->limits().maxComputeWorkGroupInvocations) {
    return make_error(ErrorCode::kInvalidArgument,
                      "workgroup " + std::to_string(desc.local_size_x) + "x" +
                          std::to_string(desc.local_size_y) + " exceeds the device's limit of " +
                          std::to_string(context->limits().maxComputeWorkGroupInvocations));
  }
  ComputePipeline p;
  p.context_ = std::move(context);
  p.desc_ = desc;
  Context& ctx = *p.context_;
  const std::string what = " for shader " + desc.shader;

  VkShaderModuleCreateInfo module_info{};
  module_info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  module_info.codeSize = spirv.size_bytes();
  module_info.pCode = spirv.data();
  VkResult result = vkCreateShaderModule(ctx.device(), &module_info, nullptr, &p.module_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateShaderModule" + what);

  std::vector<VkDescriptorSetLayoutBinding> bindings(desc.buffer_count);
  for (std::uint32_t i = 0; i < desc.buffer_count; ++i) {
    bindings[i].binding = i;
    bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo set_info{};
  set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  set_info.bindingCount = desc.buffer_count;
  set_info.pBindings = bindings.data();
  result = vkCreateDescriptorSetLayout(ctx.device(), &set_info, nullptr, &p.set_layout_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateDescriptorSetLayout" + what);

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, desc.push_constant_bytes};
  VkPipelineLayoutCreateInfo layout_info{};
  layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &p.set_layout_;
  layout_info.pushConstantRangeCount = desc.push_constant_bytes > 0 ? 1 : 0;
  layout_info.pPushConstantRanges = &range;
  result = vkCreatePipelineLayout(ctx.device(), &layout_info, nullptr, &p.layout_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreatePipelineLayout" + what);

  const std::array<std::uint32_t, 2> local{desc.local_size_x, desc.local_size_y};
  const std::array<VkSpecializationMapEntry, 2> entries{
      VkSpecializationMapEntry{0, 0, sizeof(std::uint32_t)},
      VkSpecializationMapEntry{1, sizeof(std::uint32_t), sizeof(std::uint32_t)}};
  VkSpecializationInfo specialization{};
  specialization.mapEntryCount = static_cast<std::uint32_t>(entries.size());
  specialization.pMapEntries = entries.data();
  specialization.dataSize = sizeof(local);
  specialization.pData = local.data();

  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = p.module_;
  info.stage.pName = "main";
  info.stage.pSpecializationInfo = &specialization;
  info.layout = p.layout_;
  result = vkCreateComputePipelines(ctx.device(), VK_NULL_HANDLE, 1, &info, nullptr, &p.pipeline_);
  if (result != VK_SUCCESS) return ctx.fail(result, "vkCreateComputePipelines" + what);
  return p;
}

ComputePipeline::~ComputePipeline() { release(); }

ComputePipeline::ComputePipeline(ComputePipeline&& other) noexcept { *this = std::move(other); }

ComputePipeline& ComputePipeline::operator=(ComputePipeline&& other) noexcept {
  if (this != &other) {
    release();
    context_ = std::move(other.context_);
    desc_ = std::move(other.desc_);
    module_ = std::exchange(other.module_, VK_NULL_HANDLE);
    set_layout_ = std::exchange(other.set_layout_, VK_NULL_HANDLE);
    layout_ = std::exchange(other.layout_, VK_NULL_HANDLE);
    pipeline_ = std::exchange(other.pipeline_, VK_NULL_HANDLE);
  }
  return *this;
}

void ComputePipeline::release() {
  if (!context_) return;
  VkDevice device = context_->device();
  if (pipeline_ != VK_NULL_HANDLE) vkDestroyPipeline(device, pipeline_, nullptr);
  if (layout_ != VK_NULL_HANDLE) vkDestroyPipelineLayout(device, layout_, nullptr);
  if (set_layout_ != VK_NULL_HANDLE) vkDestroyDescriptorSetLayout(device, set_layout_, nullptr);
  if (module_ != VK_NULL_HANDLE) vkDestroyShaderModule(device, module_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
  set_layout_ = VK_NULL_HANDLE;
  module_ = VK_NULL_HANDLE;
  context_.reset();
}

}  // namespace imufusion::gpu
