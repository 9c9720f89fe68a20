#pragma once
// LossRecovery: the stretch since the last fully constrained frame, and its correction once a
// loss ends (see Reconstructor::trajectory()). It keeps the frames partial ICP placed and the
// depth of the newest lost ones; from a loss's first recovering frame, the correction pending
// until the recovery completes or breaks (moved back when a recovering frame restarts the count);
// then settles the stretch: its kept frames placed backward by ICP against the model, the rest
// re-estimated by the drift model (core/drift_model.hpp).

#include <cstddef>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "core/drift_model.hpp"
#include "core/state_archive.hpp"
#include "scan/model_aligner.hpp"

namespace imufusion {

class LossRecovery {
 public:
  /// A frame as loss recovery sees it, once tracked.
  struct Frame {
    std::size_t index = 0;  // in the trajectory
    double timestamp = 0;   // s
    TrackingDecision decision;
    bool was_lost = false;   // the scan was lost before this frame
    bool restarted = false;  // the frame restarted the recovery's count (disagrees())
    bool long_loss = false;  // RelocalizationDriver::Outcome::long_loss
    // The previous pose moved by the predicted motion (dead reckoning while lost).
    Eigen::Isometry3d T_world_seed = Eigen::Isometry3d::Identity();
    // Where the frame would be without a recovery: the partial pose, else the seed.
    Eigen::Isometry3d T_world_estimate = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  // the pose it took
    Eigen::Matrix3d fixed = Eigen::Matrix3d::Zero();  // world translation directions ICP fixed
    int directions = 0;  // the directions a partial ICP fixed (IcpQuality::constrained_directions)
  };

  LossRecovery() = default;
  explicit LossRecovery(const ReconstructorConfig& config);

  /// The last fully constrained frame (ICP placed it in every direction, or its pose was given):
  /// its timestamp (s) and index in the trajectory.
  double constrained_time() const { return constrained_time_; }
  std::size_t constrained_index() const { return constrained_index_; }

  /// ReconstructorConfig::recovery.agreement_distance: whether a recovering frame (`status`,
  /// before its step) whose ICP settled at T_world_icp lies too far from its seed to agree with
  /// the frames counted before it.
  bool disagrees(TrackingStatus status, const IcpResult& icp, const MotionPrediction& prediction,
                 const Eigen::Isometry3d& T_world_seed, const Eigen::Isometry3d& T_world_icp) const;

  /// A frame just appended to `trajectory`: a restarted recovery's frames go back to dead
  /// reckoning, a loss's first recovering frame starts the pending correction (and corrects the
  /// velocity `navigator` carried out of the loss), a partial frame is recorded, and the stretch
  /// starts again at a fully constrained frame or keeps this one's depth. A stretch the frame
  /// ends (a recovery, or a broken one) is settled. Returns the frames settle() placed.
  Result<std::size_t> on_frame(const Frame& frame, const DepthView& depth,
                               InertialNavigator* navigator, Trajectory& trajectory,
                               ModelAligner& model, FrameTimings& timings);
  /// Settles the pending stretch at trajectory.back(): its kept frames placed backward from the
  /// recovering ones, the rest re-estimated; `model`'s reference goes back to the last pose.
  /// Returns the frames placed; 0 and no change when no correction is pending.
  Result<std::size_t> settle(Trajectory& trajectory, ModelAligner& model, FrameTimings& timings);
  /// A frame at a known pose: the stretch starts again there, no correction pending.
  void on_known_pose(std::size_t index, double timestamp, const InertialNavigator* navigator);
  void reset();
  void describe(StateArchive& archive);  // the changing state, for a saved scan

 private:
  // A frame partial ICP placed since the last fully constrained one.
  struct PartialFrame {
    std::size_t index = 0;
    Eigen::Matrix3d fixed;  // world translation directions partial ICP fixed
    Eigen::Vector3d moved;  // the frame's move from its dead-reckoned seed (world)
    // Its turn from the seed, R = Exp(turned) * R_seed (world, rad), where it fixed more than a
    // plane's directions; zero on a wall, whose tilts the frame measures.
    Eigen::Vector3d turned;
    bool measured = false;  // after a long loss: the move is a measurement, not exact
    void describe(StateArchive& archive);
  };
  // A frame's depth copied packed, in its own format (uint16 units, DEPTH16 or float metres).
  struct DepthCopy {
    DepthView layout;  // data and stride unused
    std::vector<std::byte> bytes;
    static DepthCopy of(const DepthView& depth);
    DepthView view() const;
    void describe(StateArchive& archive);
  };
  using KeptDepth = std::deque<std::pair<std::size_t, DepthCopy>>;
  // The end of a lost stretch back to `anchor`: frame `index` (the first that ICP placed after
  // the loss, or the oldest the retrack placed) and where dead reckoning had put it.
  struct StretchEnd {
    std::size_t anchor = 0, index = 0;
    Eigen::Isometry3d estimate, corrected;
    DriftPrior prior;
    std::vector<PartialFrame> fixed;
    void describe(StateArchive& archive);
  };
  // From a loss's first recovering frame: the stretch's end, and the lost frames' depth kept.
  struct PendingCorrection {
    StretchEnd end;
    KeptDepth depth;
    bool inertial = false;  // dead reckoning had the IMU: its motion seeds the backward frames
    void describe(StateArchive& archive);
  };
  using Placed = std::vector<std::pair<std::size_t, Eigen::Isometry3d>>;
  // What retrack() returns (see there).
  struct Retracked {
    StretchEnd end;
    Placed placed;
    bool moved_reference = false;
  };

  static const PartialFrame* find_partial(const std::vector<PartialFrame>& frames,
                                          std::size_t index);
  void constrain(std::size_t index, double timestamp, const InertialNavigator* navigator);
  void keep_depth(KeptDepth& kept, std::size_t index, const DepthView& depth) const;
  void restart_pending(const Frame& frame, Trajectory& trajectory);
  void start_pending(const Frame& frame, const Trajectory& trajectory,
                     InertialNavigator* navigator);
  void update_stretch(const Frame& frame, const DepthView& depth,
                      const InertialNavigator* navigator);
  Result<Retracked> retrack(const PendingCorrection& c, const Trajectory& trajectory,
                            ModelAligner& model) const;
  void correct_stretch(const StretchEnd& c, const Placed& placed, Trajectory& trajectory) const;
  std::optional<Eigen::Vector3d> end_velocity_error(const StretchEnd& c, double end_time,
                                                    const Trajectory& trajectory) const;
  static StretchCorrection end_error(const StretchEnd& c);
  std::vector<StretchFrame> stretch_frames(const StretchEnd& c, const Placed& placed,
                                           const Trajectory& trajectory) const;
  DriftPrior drift_prior(const InertialNavigator* navigator) const;

  LossSmoothingConfig smoothing_;
  RecoveryConfig recovery_;
  double gyro_noise_density_ = 0;         // rad/s/sqrt(Hz): InertialConfig::gyro_noise_density
  double max_translation_condition_ = 0;  // RelocalizationConfig::max_translation_condition

  double constrained_time_ = 0;        // s
  std::size_t constrained_index_ = 0;  // in the trajectory
  DriftPrior constrained_prior_;       // the inertial estimates at that frame
  std::vector<PartialFrame> partial_;  // since that frame, sorted by index
  // The depth of the newest frames since that frame (dead-reckoned or partial), at most
  // smoothing.retrack_frames: a recovery places them backward.
  KeptDepth lost_depth_;
  std::optional<PendingCorrection> pending_;
};

}  // namespace imufusion
