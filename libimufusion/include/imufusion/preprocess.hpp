#pragma once
// Depth preprocessing on the GPU: raw 16-bit depth -> metres -> bilateral filter -> a pyramid of
// half-resolution levels -> vertex and normal maps per level (camera frame, metres). The filter
// runs at the finest level whose maps are made (level 0 here; the scanner's tracking level):
// coarser levels are reduced from the filtered one, finer ones hold the unfiltered pyramid.

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
  int bilateral_radius = 3;             // full-size pixels (7x7 window); halved per level
  float bilateral_sigma_space = 4.5f;   // full-size pixels; halved per level
  float bilateral_sigma_depth = 0.03f;  // metres
  /// Depth jumps above this fraction of the depth count as discontinuities: the pyramid does not
  /// average across them and normals are not taken across them.
  float max_jump_fraction = 0.05f;
  int workgroup_x = 16;  // compute workgroup size (specialization constants)
  int workgroup_y = 16;

  Status validate() const;
};

/// The bilateral filter's radius at pyramid `level`: bilateral_radius halved per level, rounded
/// down, at least 1 (0 stays 0). Level 1 of the 7x7 default: 3x3.
int bilateral_radius_at_level(const PreprocessConfig& config, int level);
/// Its spatial sigma at `level` (pixels of that level): bilateral_sigma_space halved per level.
float bilateral_sigma_space_at_level(const PreprocessConfig& config, int level);

/// One preprocessed frame, downloaded to the host.
struct PreprocessedFrame {
  FloatImage raw_depth;               // level 0, metres, before filtering (for fusion)
  std::vector<FloatImage> depth;      // per level, metres: filtered at the first map level
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
