#pragma once
// The scanner as one object: per depth frame, IMU-seeded frame-to-model ICP, the tracking state
// machine (tracking.hpp), fusion into the sparse TSDF volume and the raycast of the model that
// the next frame is aligned to (Niessner, Dai and Fisher, EG 2014, Figure 2).
//
// Per frame t (track_and_fuse):
//   1. depth preprocessing and pyramid (GPU);
//   2. dIMU = InertialEstimate(t-1, t) from the gyro (identity without IMU data); seed
//      T_world_t = T_world_{t-1} * dIMU;
//   3. ICP of the frame against the model raycast from T_world_{t-1} (GPU association and
//      reduction, host Gauss-Newton), capped at icp.max_total_iterations Gauss-Newton steps
//      (tracking.recovery_icp_iterations while lost or recovering);
//   4. the state machine takes the ICP pose if ICP is reliable, else the dead-reckoned seed,
//      and decides whether the frame is fused;
//   5. fusion (GPU) when decided, then the raycast from the frame's pose (GPU) for frame t+1.
// The first frame with depth defines the world (config.initial_pose) and is fused: frames
// before it (a sensor's first frames are often empty) have fewer valid depth pixels than ICP's
// reliability test needs inliers (icp.reliability.min_inliers), so nothing could ever be
// tracked against them; they report status lost at the initial pose, fuse nothing, and the scan
// starts at the next frame that has them. While lost nothing is
// fused, and ICP keeps trying against the model raycast from the dead-reckoned pose: recovery
// is ICP converging reliably onto the already scanned model.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "imufusion/device.hpp"
#include "imufusion/fusion.hpp"
#include "imufusion/icp.hpp"
#include "imufusion/inertial.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/result.hpp"
#include "imufusion/tracking.hpp"
#include "imufusion/types.hpp"
#include "imufusion/volume.hpp"

namespace imufusion {

struct ReconstructorConfig {
  Intrinsics intrinsics;  // of the depth camera; frames must have its size
  PreprocessConfig preprocess;
  /// max_total_iterations: the per-frame cap while tracking. With icp.depth_noise, ICP's residual
  /// test accepts r / sum(w) up to sigma_cur^2 + sigma_model^2 <= 2 mean sigma(z)^2 over the
  /// frame, when that is above icp.reliability.max_residual_per_weight: a far scene is noisier,
  /// not misaligned.
  IcpConfig icp;
  VolumeConfig volume;
  TrackingConfig tracking;
  /// false: the baseline without inertial data, dIMU = identity (samples passed are ignored).
  bool use_imu = true;
  /// Pixels: while tracking on the IMU's prediction of rotation and translation, ICP starts at
  /// the finest pyramid level where 3 sigma of the seed's image motion (f times the rotation
  /// sigma plus the translation sigma over the median depth) is within this many of the level's
  /// pixels. Lost and recovering frames and the baseline without the IMU keep the pyramid;
  /// 0: always the pyramid. Default 16 (bench/README.md: 4 cost TUM fr1_xyz at frame step 4
  /// 0.9 mm of ATE under the 2-iteration cap).
  double imu_seed_reach_pixels = 16;
  /// While tracking on the IMU's prediction of rotation and translation, the prediction enters
  /// ICP's Gauss-Newton steps as a measurement with its sigmas (IcpConfig::seed_prior); the
  /// agreement test (IcpConfig::seed_agreement_chi2) runs either way. Default off: the prior is
  /// on the motion from the previous pose, whose own error it then holds (bench/README.md).
  bool imu_prior = false;
  InertialConfig inertial;
  /// While tracking with an IMU prediction of both rotation and translation, solve ICP
  /// degeneracy-aware (IcpConfig::keep_seed_in_degenerate_directions): a frame whose only fault
  /// is a poorly conditioned system (a bare wall) keeps tracking with pose source icp_partial
  /// instead of being lost. Without an IMU prediction the seed is no estimate of the motion, and
  /// such frames are lost as before.
  bool partial_icp_with_imu = true;
  /// With partial_icp_with_imu, while tracking on a settled inertial prediction
  /// (MotionPrediction::translation_inertial): check ICP's motion along weakly constrained
  /// directions against the prediction's sigmas (IcpConfig::seed_gate_*). A direction that moved
  /// beyond seed_gate_sigmas keeps the prediction (icp_partial, frames.csv imu_disagreement), and
  /// the frames after it are checked at seed_gate_hold_sigmas until one agrees again. Off by
  /// default: on the synthetic wall scans it halves a slide that full ICP fuses (seed 214: 71 ->
  /// 23 mm) and leaves 26 of 29 scans as they were, but on the TUM fr1_xyz recording the
  /// prediction's sigmas understate its error (disagreements of 5-14 sigma where ICP tracks), the
  /// gate fires on most frames and the scan is lost (bench/README.md).
  bool seed_gate_with_imu = false;
  /// s: the longest run of partial frames since the last fully constrained one; beyond it a
  /// partial frame counts as unreliable (lost, not fused). The IMU's unconstrained directions
  /// drift: dead reckoning the wall scene (bench/inertial_models, 10 seeds, accelerometer model)
  /// drifts 8 / 12 mm (median / p95) after 0.5 s, 14 / 21 mm after 0.8 s, 19 / 28 mm after 1 s
  /// and 56 / 99 mm after 2 s; 0.8 s keeps the p95 near 2 cm, inside the 3 cm a scan may be off.
  double max_partial_seconds = 0.8;
  /// Relocalization while lost, with the gyro's rotation (IMU runs only): every
  /// `relocalization_interval` lost frames, the frame's coarsest-level points are matched to a
  /// distance field of the model (cells of `relocalization_cell` metres) over the translations
  /// within a radius of the dead-reckoned position, at the dead-reckoned rotation, and full ICP
  /// runs from the `relocalization_candidates` best fits. A candidate whose ICP is reliable in all
  /// six directions and converged takes the frame (status recovering: the usual hysteresis
  /// follows), unless another candidate's ICP fits elsewhere but for the condition number (the
  /// view is ambiguous: nothing is taken). Once the radius exceeds the coarsest ICP level's
  /// max_distance, a reliable ICP from the dead-reckoned seed no longer ends the loss by itself:
  /// the search must confirm it. The radius grows as the drift of double-integrating a false acceleration of
  /// `relocalization_drift_acceleration` (m/s^2) since the last fully constrained frame, from the
  /// coarsest ICP level's max_distance up to `relocalization_max_radius`: 0.17 m/s^2 is gravity
  /// leaking through a 1 degree tilt error, what the gyro noise of phone-grade IMUs (0.003
  /// rad/s/sqrt(Hz), as in the shared sequences) and its bias error accumulate in about 4 s.
  /// Dead reckoning may lie beyond the search (metres after 8 s), so the same radius is also
  /// searched around where the scan was lost (the last fully constrained frame), and the best
  /// distinct fits of both are tried.
  bool relocalize_with_imu = true;
  int relocalization_interval = 5;
  double relocalization_cell = 0.05;
  int relocalization_candidates = 3;
  double relocalization_drift_acceleration = 0.17;
  double relocalization_max_radius = 1.5;
  /// When a loss ends, the lost stretch is re-estimated as the conditional mean of dead
  /// reckoning's errors given the error the recovery measured, with the inertial estimates'
  /// reported sigmas as the prior, scaled by these factors: on synthetic wall scans the gyro bias
  /// sigma is about 3 times the actual error, the gravity and accelerometer bias sigmas about
  /// 2.3 times smaller than it (bench/scan_claims: RMS of error / sigma over 12 scans).
  double drift_gyro_bias_sigma_scale = 0.3;
  double drift_gravity_sigma_scale = 2.3;
  /// When a loss ends, the lost frames are first placed by ICP backward from the recovery, each
  /// seeded by the frame after it and dead reckoning's motion between the two, until one is not
  /// reliable (a camera turning back from a bare wall sees the model for a while before the
  /// forward search can confirm a pose); the drift model re-estimates only the frames before.
  /// Their depth is kept while lost: the newest `retrack_lost_frames` frames (0: none, no
  /// backward placement), at 2 bytes per pixel (150 frames of 640x480: 92 MB).
  int retrack_lost_frames = 150;
  /// The frames so placed measure the drift where the loss ended, each its position error with
  /// this sigma per axis (m): a few frames show how fast the error still grew there. 0: only
  /// the oldest one's error is used, as the stretch's end.
  double retracked_frame_sigma = 0.003;
  /// After a long loss (the dead-reckoned seed beyond ICP's reach), a frame that partial ICP
  /// places along directions the frame before it did not fix (the camera finds the model again
  /// along a wall) moves its pose by the drift accumulated there. The re-estimation takes that
  /// move as a measurement of the drift, with this sigma per axis (m), as long as it agrees with
  /// the error the recovery measured (a partial alignment that settled on the wrong stretch of
  /// the model does not); 0: such frames count as dead-reckoned.
  double partial_move_sigma = 0.01;
  /// m: while recovering with a predicted translation, a frame whose ICP settles farther than
  /// this from its seed (the previous recovering frame's pose moved by the IMU's prediction)
  /// disagrees with the frames counted so far: one of them fit the model at the wrong place (a
  /// wall's well-conditioned wrong fit). The recovery's count starts again from this frame
  /// (FrameResult::recovery_restarted), the velocity the jump would imply is forgotten, and the
  /// frames counted before it rejoin the lost stretch, re-placed when the recovery ends. 0: off.
  /// Measured (bench/README.md): over 54 recoveries in 52 wall scans (`imu-2`, `imu-1`),
  /// recovering frames that agreed moved at most 32.6 mm from their seed (the velocity dead
  /// reckoning carried through a long loss; the frame after, at most 8.9 mm); the one wrong fit
  /// seen moved 67.1 mm. With correct_velocity_after_loss, over 46 recoveries in 44 `imu-2`
  /// wall scans, at most 15.4 mm (median 2.9).
  double recovery_agreement_distance = 0.05;
  /// The first frame placed after a loss measures how far dead reckoning drifted; the drift
  /// model (see trajectory()) turns that into the velocity error dead reckoning carried out of
  /// the loss, which is taken off the navigator's velocity before the next frame is predicted.
  /// Not where the drift is more than the model's prior allows (chi-square above its 99.9th
  /// percentile: a pose already off when the loss began, as after a slide along a wall, whose
  /// error is no velocity). Off: the next frame is seeded with the dead-reckoned velocity.
  bool correct_velocity_after_loss = true;
  DeviceOptions device;
  /// Convergence (per-step rotation, rad, and translation, m) that counts while lost or
  /// recovering: an update below it means ICP has settled onto the model (1 mm / 0.06 deg per
  /// step is below what ICP resolves on noisy depth; tighter, noise keeps it from settling).
  double recovery_converged_rotation = 1e-3;
  double recovery_converged_translation = 1e-3;
  /// T_world_camera of the first frame (metres).
  Eigen::Isometry3d initial_pose = Eigen::Isometry3d::Identity();

  /// Fails naming the first setting out of range.
  Status validate() const;
};

/// Wall-clock milliseconds of a frame's stages (host + GPU), and the GPU time of each kernel
/// where the device has timestamps.
struct FrameTimings {
  double preprocess_ms = 0;
  double icp_ms = 0;
  double integrate_ms = 0;
  double raycast_ms = 0;
  double relocalize_ms = 0;  // the relocalization search with its raycasts and ICP, when it ran
  double retrack_ms = 0;     // a recovery's backward placement and re-estimation of the loss
  double total_ms = 0;
  std::vector<KernelTiming> kernels;
};

struct FrameResult {
  std::size_t index = 0;  // 0 for the first frame since create() or reset()
  double timestamp = 0;   // seconds
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  TrackingStatus status = TrackingStatus::kTracking;
  PoseSource source = PoseSource::kInitial;
  bool fused = false;
  bool recovered = false;  // this frame ended a loss
  /// Frames of the loss this recovery (or this frame's break of one) placed by ICP backward
  /// (their poses in trajectory()). For the last frame of a scan that ends while recovering, the
  /// scanner adds those finish() placed.
  std::size_t retracked = 0;
  /// The frame's pose came from a relocalization search (ReconstructorConfig::relocalize_with_imu)
  /// rather than from ICP started at the dead-reckoned pose.
  bool relocalized = false;
  /// This recovering frame disagreed with the ones counted before it and started the recovery's
  /// count again (ReconstructorConfig::recovery_agreement_distance).
  bool recovery_restarted = false;
  /// ICP of this frame against the model (not run for the first frame or known poses).
  bool icp_ran = false;
  IcpResult icp;
  /// The IMU's prediction dIMU of the motion since the previous frame (identity when none).
  MotionPrediction imu;
  InertialStatus inertial;
  IntegrationStats integration;  // when fused
  FrameTimings timings;
};

class Reconstructor {
 public:
  static Result<Reconstructor> create(const ReconstructorConfig& config);
  ~Reconstructor();
  Reconstructor(Reconstructor&&) noexcept;
  Reconstructor& operator=(Reconstructor&&) noexcept;

  /// Tracks one depth frame (timestamp in seconds, strictly increasing; `color` registered to the
  /// depth image, or null) and fuses it when tracking is reliable. `imu` holds the samples that
  /// arrived since the previous call, oldest first (they may reach past or fall short of the
  /// frame; see inertial.hpp). Errors (a frame of the wrong size, a non-increasing timestamp,
  /// NaN or out-of-order IMU samples, a lost device) change nothing; poor tracking is not an
  /// error but a status in the result.
  Result<FrameResult> track_and_fuse(double timestamp, const DepthImage& depth,
                                     const ColorImage* color = nullptr,
                                     std::span<const ImuSample> imu = {});
  /// Fuses a frame at a known pose (ground truth or external tracking): no ICP, pose source
  /// `known`. IMU samples still feed the inertial estimators.
  Result<FrameResult> fuse_with_pose(double timestamp, const DepthImage& depth,
                                     const ColorImage* color,
                                     const Eigen::Isometry3d& T_world_camera,
                                     std::span<const ImuSample> imu = {});

  /// Ends the scan after its last frame. A scan that ends while recovering holds a lost stretch
  /// whose end ICP placed but the hysteresis has not confirmed yet: it is settled as a broken
  /// recovery's is (see trajectory()), its kept frames placed backward from the recovering ones
  /// and the rest re-estimated. Returns the frames so placed; 0 and no change when no recovery is
  /// under way (a second call, a scan that ends tracking or lost). Frames may still follow: the
  /// recovery goes on counting, its stretch already settled.
  Result<std::size_t> finish();

  /// Marching cubes over the allocated blocks (welded vertices, normals, colours).
  Result<Mesh> extract_mesh(const MeshOptions& options = {}) const;
  /// The model seen from a pose (default: the depth camera's intrinsics and depth range).
  Result<RaycastImages> raycast(const Eigen::Isometry3d& T_world_camera,
                                std::optional<Intrinsics> intrinsics = std::nullopt,
                                std::optional<std::pair<float, float>> depth_range = std::nullopt);
  Result<HostVolume> snapshot() const;
  /// Empties the volume and forgets the trajectory; the next frame starts a new scan. The IMU
  /// calibration estimates (gyro bias, mounting rotation) are kept.
  Status reset();

  /// One pose per frame since create() or reset(). When a loss ends in tracking again, the poses of
  /// the frames in between (dead-reckoned or partial, never fused) are re-estimated: the newest by
  /// ICP backward from the recovery while it is reliable
  /// (ReconstructorConfig::retrack_lost_frames), the rest back to the last fully constrained frame
  /// from the error at the recovery and the errors of the frames so placed (their ICP poses against
  /// where dead reckoning put them; ReconstructorConfig::retracked_frame_sigma): the conditional
  /// mean of dead reckoning's errors given those, under the navigator's sigmas when the loss began.
  /// With retracked_frame_sigma 0, the end is the oldest frame placed, its error measured from
  /// where dead reckoning put it before any move partial ICP made there. The rotation error is the
  /// gyro bias error (linear in time) plus the gyro's noise (a random walk); it tilts the gravity
  /// the accelerometer model removes (drift cubic in time), to which a velocity error (linear) and
  /// an accelerometer bias error (quadratic) add. Along the directions partial ICP fixed in a frame
  /// (the distance to a bare wall), the drift starts again from zero there; after a long loss, a
  /// frame's move along directions newly fixed measures the drift before it
  /// (ReconstructorConfig::partial_move_sigma; drift_corrections in src/core/relocalizer.hpp).
  /// Recovering frames that a later one disagreed with (FrameResult::recovery_restarted) belong
  /// to the stretch: they are re-estimated with it. A recovery that breaks (a recovering frame
  /// fails, the scan is lost again) ends the stretch before it the same way, at its recovering
  /// frames: they keep their ICP poses, from which the next lost frames are dead-reckoned. So
  /// does a scan that ends while recovering, at finish().
  /// FrameResult keeps the pose each frame had when it was tracked.
  const Trajectory& trajectory() const;
  const ReconstructorConfig& config() const;
  const DeviceInfo& device() const;
  std::uint32_t allocated_blocks() const;
  std::uint64_t memory_bytes() const;
  std::uint32_t validation_error_count() const;

 private:
  struct Impl;
  explicit Reconstructor(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imufusion
