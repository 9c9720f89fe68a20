#include "imufusion/result.hpp"

namespace imufusion {

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument:
      return "invalid argument";
    case ErrorCode::kNotFound:
      return "not found";
    case ErrorCode::kIoError:
      return "i/o error";
    case ErrorCode::kParseError:
      return "parse error";
    case ErrorCode::kUnsupported:
      return "unsupported";
    case ErrorCode::kNoDevice:
      return "no device";
    case ErrorCode::kOutOfDeviceMemory:
      return "out of device memory";
    case ErrorCode::kDeviceLost:
      return "device lost";
    case ErrorCode::kVulkanError:
      return "Vulkan error";
    case ErrorCode::kInternal:
      return "internal error";
  }
  return "unknown error";
}

std::string Error::describe() const {
  std::string text = std::string(to_string(code)) + ": " + message;
  if (vk_result != 0) text += " (VkResult " + std::to_string(vk_result) + ")";
  return text;
}

BadResultAccess::BadResultAccess(const Error& held)
    : std::logic_error("value() of a Result holding an error: " + held.describe()), error_(held) {}

BadResultAccess::BadResultAccess() : std::logic_error("error() of a Result holding a value") {}

}  // namespace imufusion
