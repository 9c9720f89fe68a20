#pragma once
// The tracking state machine of the scanner (Figure 2 of Niessner, Dai and Fisher, EG 2014, made
// explicit): it decides, from the reliability of each frame's ICP, which pose a frame takes and
// whether the frame is fused into the volume. Pure logic, no GPU.
//
//   tracking   --ICP reliable-->                      tracking     pose: ICP,   fused
//   tracking   --ICP partial, may fuse-->             tracking     pose: ICP partial, fused
//   tracking   --ICP partial, may not fuse-->         lost         pose: ICP partial, not fused
//   tracking   --ICP unreliable-->                    lost         pose: dead reckoning, not fused
//   lost       --ICP unreliable-->                    lost         pose: dead reckoning, not fused
//   lost       --ICP reliable and converged-->        recovering   pose: ICP,   not fused
//   lost       --relocalized, reliable, converged-->  tracking     pose: ICP,   fused
//                (with relocalized_recovery_frames 1; k frames: recovering, counted as
//                 recovery_frames - k + 1)
//   recovering --reliable and converged, k-th time--> tracking once k == recovery_frames, fused
//   recovering --reliable, not converged-->           recovering   pose: ICP (count unchanged)
//   recovering --ICP unreliable-->                    lost         pose: dead reckoning, not fused
//   lost / recovering --ICP partial-->                lost         pose: ICP partial, not fused
//   recovering --restart_recovery(), then reliable and converged--> recovering, count 1
//
// restart_recovery() is the caller's verdict that a recovering frame disagrees with the ones
// counted before it (ICP settled far from where their poses and the motion since put it): one of
// them fit the model at the wrong place, so the count starts again from this frame.
//
// "ICP partial" (IcpResult::partial) is an IMU-seeded alignment that passed every test but the
// condition number: ICP moved the pose along the directions the depth constrains and the IMU's
// prediction stands in the others. Fusing it is safe because the unconstrained directions are
// exactly those along which the visible surface looks the same (a wall slid along itself) --
// for a while: the caller says whether a partial frame may still be fused (the IMU's share drifts
// with time). A partial pose is always better than dead reckoning, so lost frames take it too,
// but it never counts towards recovery, which must be confirmed in all six directions. Without
// the IMU only lost frames are placed partly, from the frame before moved on by the last motion
// (ReconstructorConfig::recovery.partial_without_imu).
//
// The first frame of a scan (or after reset) defines the world: status tracking, pose source
// `initial`, fused. (The Reconstructor starts the machine at the first frame with depth enough to
// track against; the empty frames before it are lost at the initial pose.) Dead reckoning means
// M_{t-1} * dIMU: the previous pose moved by the IMU's estimate of the motion (identity rotation
// when there is no IMU data).

#include <deque>
#include <optional>
#include <string_view>

namespace imufusion {

class StateArchive;  // src/core/state_archive.hpp

enum class TrackingStatus { kTracking, kLost, kRecovering };
enum class PoseSource { kInitial, kIcp, kIcpPartial, kDeadReckoning, kKnown };

const char* to_string(TrackingStatus status);  // "tracking", "lost", "recovering"
/// "initial", "icp", "icp_partial", "dead_reckoning", "known"
const char* to_string(PoseSource source);
std::optional<TrackingStatus> parse_tracking_status(std::string_view name);
std::optional<PoseSource> parse_pose_source(std::string_view name);

struct TrackingConfig {
  /// Consecutive reliable, converged frames after a loss before fusion resumes (hysteresis: one
  /// lucky alignment against a half-seen model must not smear a wrong pose into the volume).
  int recovery_frames = 3;
  /// The same for a loss ended by the relocalization search, which already confirmed the frame
  /// as the only fit within dead reckoning's reach: 1 (default) fuses from that frame on; at most
  /// recovery_frames (bench/README.md, "A loss ended by the relocalization search").
  int relocalized_recovery_frames = 1;
  /// A scan lost for `restart_lost_frames` frames in a row while its model holds at most
  /// `restart_model_frames` fused frames starts again at the current frame, from its current
  /// pose, on a new model: a start that never tracked (a hand or a blur in the first frame) has
  /// no model worth searching for. Default 10 (a third of a second at 30 fps: two relocalization
  /// searches) and 3 (the frames a recovery needs); 0: never.
  int restart_lost_frames = 10;
  int restart_model_frames = 3;
  /// The pairing test follows what aligned frames of this scan pair: a frame must pair at least
  /// `pairing_ratio` of the median over the last `pairing_window` frames ICP tracked in all six
  /// directions, where that is below IcpReliabilityThresholds' min_inlier_fraction /
  /// min_pixel_fraction, and never less than `pairing_floor` (bench/README.md, "Pairing").
  int pairing_window = 15;
  double pairing_ratio = 0.7;
  double pairing_floor = 0.15;
  /// The residual test follows the noise this scan's aligned frames show: a frame's r / sum(w)
  /// may reach `residual_ratio` times its mean depth-noise variance times the median ratio of
  /// r / sum(w) to that variance over the same pairing_window frames, where that is below the
  /// limit widened to the noise model, never below the fixed limit (bench/README.md, "The
  /// residual against the scan's own"). 0: off. Default 5.
  double residual_ratio = 5;
  /// The IMU prediction's sigmas are scaled by what this scan shows: sqrt of the median chi^2
  /// (6 dof) of ICP's move from the prediction over the last `prediction_window` frames ICP
  /// tracked on its own, over chi^2's median (5.35), never below 1 (bench/README.md). 0: off.
  int prediction_window = 30;
  /// Without the IMU, ICP starts from the previous pose moved by the mean velocity over up to
  /// this many of the last frame pairs that ICP tracked (constant velocity: a hand-held camera's
  /// motion is smooth, one pair's estimate is noisy); 0: from the previous pose.
  int constant_velocity_pairs = 2;
};

/// What aligned frames of this scan pair against the model and what residual they leave (the
/// medians of IcpQuality's inlier_fraction, pixel_fraction and residual_per_weight over the
/// frame's depth-noise variance, over the last TrackingConfig::pairing_window reliable frames):
/// the depth's noise and the model's coverage set them, not the alignment.
class PairingReference {
 public:
  explicit PairingReference(const TrackingConfig& config = {}) : config_(config) {}
  /// A frame ICP tracked in all six directions paired these fractions.
  void add(double inlier_fraction, double pixel_fraction);
  /// Such a frame left r / sum(w) `residual_per_weight` (m^2) at a mean depth-noise variance
  /// `noise_variance` (m^2, DepthNoiseModel::mean_variance); ignored unless both are positive.
  void add_residual(double residual_per_weight, double noise_variance);
  /// The thresholds `base` lowered to what this scan's aligned frames pair (see TrackingConfig);
  /// `base` itself before any frame was added.
  void apply(double& min_inlier_fraction, double& min_pixel_fraction) const;
  /// The residual test's limit (r / sum(w), m^2) for a frame of mean depth-noise variance
  /// `noise_variance` (m^2): TrackingConfig::residual_ratio times it times the median ratio
  /// the scan's aligned frames showed, within [`fixed`, `widened`] (the fixed limit and the
  /// limit widened to the noise model); `widened` before any residual was added.
  double residual_limit(double fixed, double widened, double noise_variance) const;
  void reset();
  std::size_t size() const { return inlier_.size(); }
  std::size_t residuals() const { return residual_.size(); }
  /// Writes or reads the changing state (not the configuration) for a saved scan.
  void describe(StateArchive& archive);

 private:
  TrackingConfig config_;
  std::deque<double> inlier_, pixel_;
  std::deque<double> residual_;  // r / sum(w) over the frame's depth-noise variance
};

/// How far the IMU's prediction is off on this scan relative to its own sigmas
/// (TrackingConfig::prediction_window): the scale its sigmas take before ICP's agreement test.
class PredictionCalibration {
 public:
  explicit PredictionCalibration(const TrackingConfig& config = {}) : config_(config) {}
  /// A frame ICP tracked on its own, whose move from the prediction had `chi2` (6 dof) under
  /// the prediction's sigmas times scale(): the seed's covariance dominating ICP's, chi2 at
  /// unit scale is chi2 * scale()^2.
  void add(double chi2);
  /// The factor on the prediction's sigmas, at least 1 (1 before any frame was added).
  double scale() const;
  void reset() { chi2_.clear(); }
  std::size_t size() const { return chi2_.size(); }
  /// Writes or reads the changing state (not the configuration) for a saved scan.
  void describe(StateArchive& archive);

 private:
  TrackingConfig config_;
  std::deque<double> chi2_;  // at unit scale
};

struct TrackingDecision {
  TrackingStatus status = TrackingStatus::kTracking;
  PoseSource source = PoseSource::kInitial;
  bool fuse = false;
  int good_frames = 0;     // consecutive reliable frames counted towards recovery
  bool recovered = false;  // this frame ended a loss (recovering -> tracking)
};

class TrackingStateMachine {
 public:
  explicit TrackingStateMachine(TrackingConfig config = {}) : config_(config) {}

  /// The first frame, or the first after reset(): defines the world frame.
  TrackingDecision start();
  /// A later frame, given its ICP verdict. `converged` is the ICP's own convergence flag; it
  /// matters only while lost or recovering, where alignment must settle before it counts.
  /// `icp_partial`: IcpResult::partial (only looked at when icp_reliable is false);
  /// `partial_may_fuse`: whether a partial frame may still be fused while tracking.
  /// `relocalized`: the relocalization search placed this lost frame (relocalized_recovery_frames).
  TrackingDecision step(bool icp_reliable, bool converged, bool icp_partial = false,
                        bool partial_may_fuse = true, bool relocalized = false);
  /// While recovering: the frames counted so far disagree with the next one, which starts the
  /// count again (step() then counts it as the first good frame). No effect in other states.
  void restart_recovery();
  /// Back to before the first frame.
  void reset();

  bool started() const { return started_; }
  TrackingStatus status() const { return status_; }
  /// Whether the next frame is tracked from a dead-reckoned seed (lost or recovering).
  bool recovering_or_lost() const { return started_ && status_ != TrackingStatus::kTracking; }
  const TrackingConfig& config() const { return config_; }
  /// Writes or reads the changing state (not the configuration) for a saved scan.
  void describe(StateArchive& archive);

 private:
  TrackingConfig config_;
  bool started_ = false;
  TrackingStatus status_ = TrackingStatus::kTracking;
  int good_frames_ = 0;
};

}  // namespace imufusion
