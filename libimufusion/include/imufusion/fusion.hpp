#pragma once
// Volumetric fusion into the sparse TSDF block volume on the GPU, and model raycasts. Poses are
// camera-to-world (T_world_camera), metres.

#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "imufusion/device.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/result.hpp"
#include "imufusion/types.hpp"
#include "imufusion/volume.hpp"

namespace imufusion {

/// What one integration did, and what went wrong without corrupting the volume.
struct IntegrationStats {
  std::uint32_t visible_blocks = 0;    // blocks touched by this frame and fused
  std::uint32_t allocated_blocks = 0;  // blocks in the pool after it
  std::uint32_t pool_full = 0;         // blocks touched by this frame that have no room in the
                                       // full pool, refused now or in an earlier frame (not fused)
  std::uint32_t table_full = 0;        // insertions that found no free hash slot (not fused)
  std::uint32_t out_of_range = 0;      // block coordinates beyond the key range (not fused)
};

/// A raycast of the model from a pose, at the depth image's resolution.
struct RaycastImages {
  Vec4Image vertices;  // camera frame of the pose, w = 1 where the ray hit the surface
  Vec4Image normals;   // camera frame, unit, w = 1 where valid
  ColorImage shaded;   // Lambertian shading with the light at the camera
  ColorImage color;    // the fused surface colour (black where never coloured)
};

class TsdfFusion {
 public:
  static Result<TsdfFusion> create(const VolumeConfig& volume, const PreprocessConfig& preprocess,
                                   const Intrinsics& intrinsics, const DeviceOptions& device = {});
  ~TsdfFusion();
  TsdfFusion(TsdfFusion&&) noexcept;
  TsdfFusion& operator=(TsdfFusion&&) noexcept;

  /// Fuses one depth frame (and its registered colour, same size) seen from T_world_camera.
  Result<IntegrationStats> integrate(const DepthImage& depth, const ColorImage* color,
                                     const Eigen::Isometry3d& T_world_camera,
                                     std::vector<KernelTiming>* timings = nullptr);
  /// Raycasts the model from T_world_camera with the fusion's intrinsics (or others), between
  /// depths near and far (metres along the optical axis; default: the preprocessing range).
  Result<RaycastImages> raycast(const Eigen::Isometry3d& T_world_camera,
                                std::optional<Intrinsics> intrinsics = std::nullopt,
                                std::vector<KernelTiming>* timings = nullptr,
                                std::optional<std::pair<float, float>> depth_range = std::nullopt);
  /// March steps of each ray (row-major pixels) of the last raycast, for profiling: 0 where no
  /// allocated block projects into the pixel's range cell.
  Result<std::vector<std::uint32_t>> last_raycast_steps() const;
  /// The allocated blocks, downloaded.
  Result<HostVolume> snapshot() const;
  Status reset();

  const DeviceInfo& device() const;
  std::uint32_t allocated_blocks() const;
  /// Bytes of GPU memory the volume holds (pool + hash table).
  std::uint64_t memory_bytes() const;
  std::uint32_t validation_error_count() const;

 private:
  struct Impl;
  explicit TsdfFusion(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imufusion
