#pragma once
// Errors that are errors (a bad file, no Vulkan device, a lost device) come back as values.
// The library never calls exit() or abort(), and throws only BadResultAccess: a caller that
// reads the value of a Result holding an error (or the error of one holding a value).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace imufusion {

enum class ErrorCode {
  kInvalidArgument,    // a value the caller passed is out of range or malformed
  kNotFound,           // a file or directory that must exist does not
  kIoError,            // reading or writing a file failed
  kParseError,         // a file exists but its content is malformed (message names file and line)
  kUnsupported,        // a valid input this build cannot handle (e.g. 8-bit depth)
  kNoDevice,           // no Vulkan instance or no usable device
  kOutOfDeviceMemory,  // VK_ERROR_OUT_OF_DEVICE_MEMORY / OUT_OF_HOST_MEMORY
  kDeviceLost,         // VK_ERROR_DEVICE_LOST: the device must be recreated
  kVulkanError,        // any other failing VkResult
  kInternal,           // a broken invariant inside imufusion
};

const char* to_string(ErrorCode code);

/// What went wrong, for a person: `message` names the file, line or value at fault.
/// `vk_result` is the VkResult (as an int, so no Vulkan header is needed) or 0.
struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;
  std::int32_t vk_result = 0;

  /// "parse error: depth.txt:12: timestamp 3.2 is not after 3.4" (plus " (VkResult -4)").
  std::string describe() const;
};

/// Thrown on a Result accessed for what it does not hold (a bug in the caller, as
/// std::bad_expected_access). what(): "value() of a Result holding an error: " plus the held
/// error's describe(), so an unchecked Result that terminates the program still says why.
class BadResultAccess : public std::logic_error {
 public:
  explicit BadResultAccess(const Error& held);  // value() of a Result holding `held`
  BadResultAccess();                            // error() of a Result holding a value
  /// The error the Result held (code kInternal and an empty message for error() on a value).
  const Error& error() const noexcept { return error_; }

 private:
  Error error_;
};

/// Either a value or an Error. `Result<void>` is an alias of `Status`. value(), `*` and `->`
/// on an error, and error() on a value, throw BadResultAccess.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : data_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : data_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return std::holds_alternative<T>(data_); }
  explicit operator bool() const { return ok(); }

  T& value() & { return checked(data_); }
  const T& value() const& { return checked(data_); }
  T&& value() && { return std::move(checked(data_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const {
    if (const Error* held = std::get_if<Error>(&data_)) return *held;
    throw BadResultAccess();
  }

 private:
  template <typename Data>
  static auto& checked(Data& data) {
    if (auto* held = std::get_if<T>(&data)) return *held;
    throw BadResultAccess(std::get<Error>(data));
  }

  std::variant<T, Error> data_;
};

/// Success or an Error.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { return error_; }

 private:
  Error error_;
  bool ok_ = true;
};

inline Error make_error(ErrorCode code, std::string message, std::int32_t vk_result = 0) {
  return Error{code, std::move(message), vk_result};
}

}  // namespace imufusion

/// Returns the error of `expr` (a Status or Result) from the enclosing function.
#define IMUFUSION_RETURN_IF_ERROR(expr)                            \
  do {                                                             \
    auto imufusion_status_ = (expr);                               \
    if (!imufusion_status_.ok()) return imufusion_status_.error(); \
  } while (false)
