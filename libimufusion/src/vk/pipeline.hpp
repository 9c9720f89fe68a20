#pragma once
// A compute pipeline built from one embedded SPIR-V shader. Every kernel's interface is the same
// shape: storage buffers at bindings 0..N-1 of set 0, one push-constant block, and the workgroup
// size as specialization constants 0 (x) and 1 (y).

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "imufusion/result.hpp"
#include "vk/context.hpp"

namespace imufusion::gpu {

/// The SPIR-V words compiled from shaders/NAME.comp at build time; empty when unknown.
std::span<const std::uint32_t> embedded_spirv(std::string_view name);

struct PipelineDesc {
  std::string shader;              // stem of shaders/NAME.comp
  std::uint32_t buffer_count = 0;  // storage buffers at bindings 0..buffer_count-1
  std::uint32_t push_constant_bytes = 0;
  std::uint32_t local_size_x = 16;  // workgroup size (specialization constants 0, 1)
  std::uint32_t local_size_y = 16;
};

class ComputePipeline {
 public:
  static Result<ComputePipeline> create(std::shared_ptr<Context> context, const PipelineDesc& desc);

  ComputePipeline() = default;
  ~ComputePipeline();
  ComputePipeline(ComputePipeline&& other) noexcept;
  ComputePipeline& operator=(ComputePipeline&& other) noexcept;
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;

  const PipelineDesc& desc() const { return desc_; }
  VkPipeline pipeline() const { return pipeline_; }
  VkPipelineLayout layout() const { return layout_; }
  VkDescriptorSetLayout set_layout() const { return set_layout_; }

 private:
  void release();

  std::shared_ptr<Context> context_;
  PipelineDesc desc_;
  VkShaderModule module_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

}  // namespace imufusion::gpu
