#pragma once
// Depth preprocessing on the GPU: raw 16-bit depth -> metres -> bilateral filter -> a pyramid of
// half-resolution levels -> vertex and normal maps per level (camera frame, metres).

#include <memory>
#include <vector>

#include "imufusion/device.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

struct PreprocessConfig {
  int levels = 3;          // pyramid levels, level 0 at full resolution
  float min_depth = 0.3f;  // metres; measurements outside [min, max] are dropped
  float max_depth = 5.0f;
  int bilateral_radius = 3;             // pixels (7x7 window)
  float bilateral_sigma_space = 4.5f;   // pixels
  float bilateral_sigma_depth = 0.03f;  // metres
  /// Depth jumps above this fraction of the depth count as discontinuities: the pyramid does not
  /// average across them and normals are not taken across them.
  float max_jump_fraction = 0.05f;
  int workgroup_x = 16;  // compute workgroup size (specialization constants)
  int workgroup_y = 16;

  Status validate() const;
};

/// One preprocessed frame, downloaded to the host.
struct PreprocessedFrame {
  FloatImage raw_depth;               // level 0, metres, before filtering (for fusion)
  std::vector<FloatImage> depth;      // per level: filtered (level 0) and downsampled, metres
  std::vector<Vec4Image> vertices;    // per level: camera-frame points, w = 1 where valid
  std::vector<Vec4Image> normals;     // per level: unit normals facing the camera, w = 1 valid
  std::vector<KernelTiming> timings;  // one per kernel dispatch
};

/// Runs the preprocessing kernels on one Vulkan device. Move-only; no Vulkan types in this header.
class DepthPreprocessor {
 public:
  static Result<DepthPreprocessor> create(const PreprocessConfig& config,
                                          const Intrinsics& intrinsics,
                                          const DeviceOptions& device = {});
  ~DepthPreprocessor();
  DepthPreprocessor(DepthPreprocessor&&) noexcept;
  DepthPreprocessor& operator=(DepthPreprocessor&&) noexcept;

  /// Processes one depth image of the configured size. Fails (never aborts) on a size mismatch,
  /// device loss or out-of-memory, with the VkResult in the Error.
  Result<PreprocessedFrame> process(const DepthView& depth);

  const DeviceInfo& device() const;
  const PreprocessConfig& config() const;
  /// Validation-layer errors seen so far (0 unless validation is enabled).
  std::uint32_t validation_error_count() const;

 private:
  struct Impl;
  explicit DepthPreprocessor(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imufusion
