#pragma once
// The ICP kernels' dispatcher: projective association (icp_associate) and the first reduction
// stage (icp_reduce) on the GPU, the second stage on the host in double.

#include <memory>
#include <vector>

#include "gpu/preprocessor.hpp"
#include "imufusion/icp.hpp"
#include "vk/buffer.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"
#include "vk/pipeline.hpp"

namespace imufusion::gpu {

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
  /// Adds the partial sums of the last run (host, double).
  Result<NormalEquations> read_equations() const;

  /// The association rows of the last run (two vec4 per pixel), for tests.
  const Buffer& rows() const { return rows_; }

 private:
  ComputePipeline associate_, reduce_;
  Buffer rows_, partials_;
  std::uint32_t groups_ = 0;  // partial sums written by the last run
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
                          int first_level = 0);
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
};

}  // namespace imufusion::gpu
