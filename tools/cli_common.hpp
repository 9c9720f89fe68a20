#pragma once
// What every command-line tool prints the same way: an error line, and the Vulkan devices.

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "imufusion/device.hpp"

namespace imufusion::tools {

/// Prints "error: MESSAGE" to stderr; returns exit status 1.
inline int fail(const std::string& message) {
  std::cerr << "error: " << message << "\n";
  return 1;
}

/// Milliseconds since `start`.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// Lists the Vulkan devices, one per line: "[index] name (type, driver, device-local MiB)".
inline int print_devices() {
  auto devices = list_devices();
  if (!devices) return fail(devices.error().describe());
  for (const DeviceInfo& d : *devices)
    std::cout << "[" << d.index << "] " << d.name << " (" << to_string(d.type) << ", " << d.driver
              << ", " << d.device_local_bytes / (1024 * 1024) << " MiB)\n";
  return 0;
}

}  // namespace imufusion::tools
