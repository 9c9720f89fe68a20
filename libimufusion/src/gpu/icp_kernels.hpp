#pragma once
// The ICP kernels' dispatcher: projective association (icp_associate) and the first reduction
// stage (icp_reduce) on the GPU, the second stage on the host in double.

#include <algorithm>
#include <memory>
#include <vector>

#include "gpu/preprocessor.hpp"
#include "imufusion/icp.hpp"
#include "vk/buffer.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"
#include "vk/pipeline.hpp"

namespace imufusion::gpu {

/// The colours of ICP's photometric term (IcpPhotometricConfig): the current frame's at full
/// resolution (`current_width` wide) and the reference's at the level ICP's level 0 runs at, both
/// RGBA8. Without both, ICP runs on depth alone.
struct PhotometricMaps {
  const Buffer* current = nullptr;
  int current_width = 0;
  const Buffer* reference = nullptr;
  IcpPhotometricConfig config;
  /// config.pixel_step, at least 1: every step-th pixel in x and y is sampled.
  int step() const { return std::max(1, config.pixel_step); }
  /// The RMS photometric residual of the last evaluation (intensity), which scales the next one's
  /// Huber threshold; read and updated when given, 0 before any.
  double* sigma = nullptr;
};

/// The maps one side of an ICP pair provides at one pyramid level.
struct IcpMaps {
  const Buffer* vertices = nullptr;
  const Buffer* normals = nullptr;
  int width = 0, height = 0;
};

class IcpKernels {
 public:
  /// Buffers sized for current frames of up to `max_pixels` pixels; `noise` weighs the pixels
  /// in the inlier fraction (NormalEquations::valid_information) and, with `gate`, widens the
  /// normal test where the depth is noisy.
  /// The reduction adds across subgroups where the device can (DeviceInfo::subgroup_arithmetic)
  /// and `subgroups` allows it, else through a shared-memory tree.
  static Result<IcpKernels> create(std::shared_ptr<Context> context, std::size_t max_pixels,
                                   int workgroup_x, int workgroup_y, const DepthNoiseModel& noise,
                                   const NormalGate& gate = {}, bool subgroups = true);

  /// Records association of `current` against `reference` (seen through `ref_intrinsics`) at
  /// the pose T_ref_cur, then the partial reduction.
  void record(CommandSequence& seq, const IcpMaps& current, const IcpMaps& reference,
              const Intrinsics& ref_intrinsics, const Eigen::Isometry3d& T_ref_cur,
              float max_distance, float min_normal_cos, int level);
  /// Dispatches record() adds.
  static constexpr std::uint32_t kDispatches = 2;
  /// Dispatches record() and record_photometric() add together.
  static constexpr std::uint32_t kPhotometricDispatches = 4;
  /// Records the photometric rows of `current` (its colours at 2^level times its resolution)
  /// against `reference` and their partial reduction, with the Huber threshold `huber`: after
  /// record() of the same pose, whose pairs are the only pixels it compares.
  void record_photometric(CommandSequence& seq, const IcpMaps& current, const IcpMaps& reference,
                          const PhotometricMaps& colors, float huber,
                          const Intrinsics& ref_intrinsics, const Eigen::Isometry3d& T_ref_cur,
                          float max_distance, int level);
  /// Adds the partial sums of the last run (host, double).
  Result<NormalEquations> read_equations() const;
  /// Adds the partial sums of the last photometric run.
  Result<NormalEquations> read_photometric() const;

  /// The depth noise model the kernels were created with: the association's information
  /// weights, and the depth variance floor of the photometric term's weighting.
  const DepthNoiseModel& depth_noise() const { return noise_; }
  /// The association rows of the last run (two vec4 per pixel), for tests.
  const Buffer& rows() const { return rows_; }

 private:
  ComputePipeline associate_, reduce_, photometric_;
  Buffer rows_, partials_, photo_rows_, photo_partials_;
  std::uint32_t groups_ = 0;        // partial sums written by the last run
  std::uint32_t photo_groups_ = 0;  // by the last photometric run
  DepthNoiseModel noise_;
  NormalGate gate_;
};

/// Runs one association + reduction per evaluate() on the device: the bridge between the
/// host ICP and the kernels. The maps are read at evaluate() time.
class GpuNormalEquationSource : public NormalEquationSource {
 public:
  /// ICP's level 0 is the pyramids' `first_level` (the tracking resolution).
  GpuNormalEquationSource(IcpKernels& kernels, CommandSequence& seq, const Preprocessor& current,
                          const Preprocessor& reference, std::vector<KernelTiming>* timings,
                          int first_level = 0, const PhotometricMaps& colors = {});
  int levels() const override { return current_.config().levels - first_level_; }
  Result<NormalEquations> evaluate(int level, const Eigen::Isometry3d& T_ref_cur,
                                   float max_distance, float min_normal_cos) override;

 private:
  IcpKernels& kernels_;
  CommandSequence& seq_;
  const Preprocessor& current_;
  const Preprocessor& reference_;
  std::vector<KernelTiming>* timings_;
  int first_level_ = 0;
  PhotometricMaps colors_;
};

}  // namespace imufusion::gpu
