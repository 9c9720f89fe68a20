// A downstream program built against an installed imufusion: public headers only, and no C++
// standard of its own (the package's target asks for the C++20 its headers need). Creates the
// scanner and fuses one flat frame. Without a Vulkan device it passes, unless
// IMUFUSION_REQUIRE_GPU is set (as in CI).
#include <cstdint>
#include <cstdlib>
#include <imufusion/presets.hpp>
#include <imufusion/reconstructor.hpp>
#include <imufusion/sequence.hpp>
#include <iostream>
#include <string>
#include <vector>

using namespace imufusion;

int main() {
  // An unchecked Result reports the error it holds.
  try {
    (void)Reconstructor::create({}).value();
    return 1;
  } catch (const BadResultAccess& e) {
    if (std::string(e.what()).find("intrinsics size 0x0 is empty") == std::string::npos) return 1;
  }

  const Intrinsics k{131.25, 131.25, 79.5, 59.5, 160, 120};  // fx fy cx cy (px), width height
  const ReconstructorConfig config = preset_config(SensorPreset::kKinect, k, /*with_imu=*/false);
  auto scanner = Reconstructor::create(config);
  if (!scanner) {
    std::cout << "consumer linked imufusion; no scanner: " << scanner.error().describe() << "\n";
    const char* required = std::getenv("IMUFUSION_REQUIRE_GPU");
    const bool no_device = scanner.error().code == ErrorCode::kNoDevice;
    return no_device && (required == nullptr || std::string(required) == "0") ? 0 : 1;
  }
  // A wall 1 m in front of the camera (depth in millimetres): the scan starts and fuses it.
  const DepthImage depth{160, 120, 1000.0, std::vector<std::uint16_t>(160 * 120, 1000)};
  auto frame = scanner->track_and_fuse(0.0, depth);
  if (!frame || !frame->fused || scanner->allocated_blocks() == 0) return 1;
  std::cout << "consumer fused a frame on " << scanner->device().name << " into "
            << scanner->allocated_blocks() << " blocks\n";
  return 0;
}
