#pragma once
// Maps failing VkResults to imufusion Errors.

#include <vulkan/vulkan.h>

#include <string>

#include "imufusion/result.hpp"

namespace imufusion::gpu {

const char* vk_result_name(VkResult result);

/// An Error whose code follows the VkResult (device lost, out of memory, ...).
Error vk_error(VkResult result, const std::string& what);

}  // namespace imufusion::gpu

/// Returns an Error from the enclosing function when the Vulkan call fails.
#define IMUFUSION_VK_CHECK(call, what)                                 \
  do {                                                                 \
    const VkResult imufusion_vk_result_ = (call);                      \
    if (imufusion_vk_result_ != VK_SUCCESS)                            \
      return ::imufusion::gpu::vk_error(imufusion_vk_result_, (what)); \
  } while (false)
