// A downstream program built against an installed imufusion: uses the public headers only.
#include <iostream>

#include <imufusion/device.hpp>
#include <imufusion/preprocess.hpp>
#include <imufusion/types.hpp>

int main() {
  imufusion::Intrinsics k{525, 525, 319.5, 239.5, 640, 480};
  const imufusion::Intrinsics half = k.at_level(1);
  imufusion::PreprocessConfig config;
  if (!config.validate().ok() || half.width != 320) return 1;
  // Linking list_devices pulls in the Vulkan runtime; a machine without a device still passes.
  auto devices = imufusion::list_devices();
  std::cout << "consumer linked imufusion; devices: "
            << (devices.ok() ? std::to_string(devices->size()) : devices.error().describe()) << "\n";
  return 0;
}
