#pragma once
// ModelAligner: the GPU work loss recovery and relocalization ask of the reconstructor (its
// current frame, the model and its raycast reference), so that neither sees the rest of it.
// Reconstructor::Impl implements it.

#include <Eigen/Geometry>
#include <vector>

#include "imufusion/reconstructor.hpp"

namespace imufusion {

class ModelAligner {
 public:
  /// An alignment of the current frame against the model and the pose it gives.
  struct Placement {
    IcpResult icp;
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  };

  virtual ~ModelAligner() = default;

  /// Makes `depth` the current frame (preprocessed as an incoming one, without colour).
  virtual Status load_frame(const DepthView& depth, FrameTimings& timings) = 0;
  /// Makes the model raycast from T_world_camera the reference the next alignment is against.
  virtual Status set_reference(const Eigen::Isometry3d& T_world_camera, FrameTimings& timings) = 0;
  /// Full six-direction ICP of the current frame (`depth`) against the model raycast from
  /// T_world_seed, with no IMU prediction and the budget of a frame that must settle.
  virtual Result<Placement> place(const DepthView& depth, const Eigen::Isometry3d& T_world_seed,
                                  FrameTimings& timings) = 0;
  /// The reliability thresholds of `depth`'s alignment.
  virtual IcpReliabilityThresholds reliability(const DepthView& depth) const = 0;
  /// The current frame's valid vertices at pyramid level `level` (camera frame, metres), with
  /// their unit normals (one per point; empty when the frame has none).
  struct FramePoints {
    std::vector<Eigen::Vector3d> points;
    std::vector<Eigen::Vector3d> normals;
  };
  virtual Result<FramePoints> frame_points(int level) = 0;
  /// A host copy of the model.
  virtual Result<HostVolume> model_snapshot() const = 0;
};

}  // namespace imufusion
