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
//      reduction, host Gauss-Newton), icp.max_total_iterations Gauss-Newton steps, more while a
//      step still moves the pose (icp.max_unsettled_iterations; recovery.icp_iterations while
//      lost or recovering);
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

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

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

/// How the IMU aids tracking. The measurements behind each default: bench/README.md,
/// "ReconstructorConfig defaults", under the field's name.
struct ImuAidConfig {
  bool enabled = true;  // false: the baseline without inertial data (dIMU = identity)
  /// px: while tracking on a predicted rotation and translation, ICP starts at the finest
  /// pyramid level whose pixels cover 3 sigma of the seed's image motion; 0: always the pyramid.
  double seed_reach_pixels = 16;
  bool prior = false;  // the prediction as a measurement in ICP's steps (IcpConfig::seed_prior)
  /// A frame whose only fault is a poorly conditioned system (a bare wall) keeps tracking along
  /// the directions ICP fixes, the rest from the IMU (pose source icp_partial).
  bool partial_icp = true;
  bool seed_gate = false;  // check weak directions against the prediction (IcpConfig::seed_gate_*)
  double max_partial_seconds = 0.8;  // s: longest partial run before its frames count as lost
};

/// The search for a lost frame's pose in the model, at the gyro's rotation (IMU runs only): a
/// distance field of the model over translations within a radius of dead reckoning's position
/// and of the last fully constrained one, scored on the frame's points spread over their
/// normals' directions (a view mostly of wall keeps all of what fixes the slide along it), then
/// full ICP from the best fits and from the estimate itself (and, while a fit waits for
/// confirmation, from the estimate at its correction). An ambiguous view (another fit elsewhere)
/// takes nothing until the next lost frame's search puts the camera at the same correction of dead
/// reckoning, with no reliable fit elsewhere repeated.
struct RelocalizationConfig {
  bool enabled = true;
  int interval = 5;    // lost frames between searches
  double cell = 0.05;  // m: the distance field's cell
  int candidates = 3;  // best fits ICP runs from
  /// m/s^2: the radius is the drift of this false acceleration since the last fully constrained
  /// frame (0.5 a t^2), from the coarsest ICP level's reach up to max_radius (m).
  double drift_acceleration = 0.17;
  double max_radius = 1.5;
  /// A search whose best fit fails only the condition number, by at most this factor of
  /// icp.reliability.max_condition, searches again at the next lost frame: the view is leaving
  /// a wall, and the next frame may constrain every direction. 0: off. Default 6.
  double near_fit_condition_factor = 6;
  /// deg: without the gyroscope the frame's orientation is lost too, and the search also turns
  /// it about its last tracked vertical (camera y) all the way round in steps of this, each
  /// tilted by one step up and down, and tries each orientation a fused frame had (one per half
  /// step) that is more than half a step from all of those, within max_radius of where it was
  /// lost (and within inertial.max_speed times the time since, which bounds every search's
  /// fits). 0: no search without the gyroscope. Default 15.
  double turn_step_deg = 15;
  /// Without the gyroscope a fit places the frame only when its kappa is at most this factor
  /// of icp.reliability.max_condition (in (0, 1]; 1: the tracking gate alone): with the orientation
  /// searched too, a view that only just fixes every direction fits coincidental structure of
  /// the model far from the camera. Default 0.5 (bench/README.md, "A fit without the gyroscope
  /// fixes every direction with a margin").
  double turned_condition_factor = 0.5;
  /// A fit elsewhere (ICP from another candidate, reliable but for the condition number; with
  /// the gyroscope, one that fixes every direction or its position) makes the view ambiguous
  /// only when its residual per weight is within this factor of the best fit's; 0: any fit
  /// elsewhere. Default 4: an RMS residual twice the best's (bench/README.md,
  /// "A rival fit must explain the view as well").
  double rival_residual_ratio = 4;
  /// ...and only when it pairs at least this share of the best fit's information-weighted
  /// inlier fraction (IcpQuality::inlier_fraction); 0: however little. Default 0.7
  /// (bench/README.md, "A rival fit must pair the view as well").
  double rival_inlier_ratio = 0.7;
  /// With the gyroscope, a fit that passes every test but the condition number places the frame
  /// when the condition of its translation alone (IcpQuality::translation_condition) is at most
  /// this: a view leaving a wall fixes the position while kappa is still large along a
  /// rotation coupled with a translation. The retrack after a recovery places a frame by the same
  /// rule. 0: off. Default 100 (bench/README.md, "A fit that fixes the position").
  double max_translation_condition = 100;
};

/// How a lost frame settles onto the model again.
struct RecoveryConfig {
  int icp_iterations = 10;              // Gauss-Newton steps per frame while lost or recovering
  double converged_rotation = 1e-3;     // rad per step that counts as settled
  double converged_translation = 1e-3;  // m per step that counts as settled
  /// m: a recovering frame settling farther than this from its predicted seed restarts the
  /// recovery's count (one of the frames counted fit the model at the wrong place); 0: off.
  double agreement_distance = 0.05;
  /// The drift the recovery measured corrects the velocity dead reckoning carried out of the loss.
  bool correct_velocity = true;
  /// Without the IMU, a lost frame takes ICP's pose along the directions the depth constrains (a
  /// wall fixes the distance to it and its two tilts), the others the seed's (the frame before
  /// moved on by the last tracked motion); it is neither fused nor counted towards recovery. Its
  /// pairing need only reach tracking.pairing_floor: a lost camera's view leaves the surface the
  /// model covers. Default on (bench/README.md, "Lost frames without the IMU held to the wall").
  bool partial_without_imu = true;
};

/// The lost stretch, re-estimated when a loss ends: its newest frames placed by ICP backward from
/// the recovery, the rest by the drift model (src/core/drift_model.hpp) with the inertial
/// estimates' sigmas as the prior.
struct LossSmoothingConfig {
  double gyro_bias_sigma_scale = 0.3;    // the prior's gyro bias sigma over the reported one
  double gravity_sigma_scale = 2.3;      // the same for gravity and the accelerometer bias
  int retrack_frames = 150;              // lost frames whose depth is kept (2 bytes/pixel); 0: none
  double retracked_frame_sigma = 0.003;  // m per axis: a backward-placed frame's position error
  double partial_move_sigma =
      0.01;  // m per axis: a partial frame's move late in a long loss; 0: off
};

/// The smallest tracking size (px) chosen by default on a CPU device: 640x480 frames track at
/// 320x240 there (ReconstructorConfig::tracking_level).
inline constexpr int kMinCpuTrackingWidth = 320;
inline constexpr int kMinCpuTrackingHeight = 240;
/// ReconstructorConfig::reference_frames chosen by default on a CPU device.
inline constexpr int kCpuReferenceFrames = 3;

struct ReconstructorConfig {
  Intrinsics intrinsics;  // of the depth camera; frames must have its size
  PreprocessConfig preprocess;
  IcpConfig icp;  // max_total_iterations: the per-frame cap while tracking
  VolumeConfig volume;
  TrackingConfig tracking;
  InertialConfig inertial;
  ImuAidConfig imu;
  RelocalizationConfig relocalization;
  RecoveryConfig recovery;
  LossSmoothingConfig smoothing;
  DeviceOptions device;
  /// Pyramid level that ICP and the model raycast run at (0: the full frame, 1: half size);
  /// fusion always takes the full frame. -1: by device, the full frame on a GPU and on a CPU
  /// device the coarsest level of at least kMinCpuTrackingWidth x Height (bench/README.md).
  int tracking_level = -1;
  /// Frames one model raycast serves as ICP's reference while tracking (1: a raycast after every
  /// frame): a frame that ICP tracked keeps the reference while it is younger than this and the
  /// view moved less than reference_motion_pixels since it. 0: by device, kCpuReferenceFrames on
  /// a CPU device (where the raycast is most of the frame; bench/README.md), 1 on a GPU.
  int reference_frames = 0;
  /// px at the tracking level: the image motion since the reference (its rotation plus its
  /// translation over the frame's median depth) from which a frame raycasts again. Default 16.
  double reference_motion_pixels = 16;
  Eigen::Isometry3d initial_pose = Eigen::Isometry3d::Identity();  // T_world_camera of frame 0, m

  /// Fails naming the first setting out of range.
  Status validate() const;
};

/// Wall-clock milliseconds of a frame's stages (host + GPU), and the GPU time of each kernel
/// where the device has timestamps.
struct FrameTimings {
  double preprocess_ms = 0;  // upload and submit; its GPU time falls in the next stage's wait
  double icp_ms = 0;
  /// Integration and raycast share one submission, split between them by their kernels' GPU time.
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
  /// The frame's pose came from a relocalization search
  /// (ReconstructorConfig::relocalization.enabled) rather than from ICP started at the
  /// dead-reckoned pose.
  bool relocalized = false;
  /// This recovering frame disagreed with the ones counted before it and started the recovery's
  /// count again (ReconstructorConfig::recovery.agreement_distance).
  bool recovery_restarted = false;
  /// The scan started again at this frame on a new model, from the last frame's pose, after a
  /// loss at its start (TrackingConfig::restart_lost_frames); the earlier frames keep their poses.
  bool restarted = false;
  /// The model was raycast from this frame's pose as the next frame's ICP reference; false when
  /// the reference before it still serves (ReconstructorConfig::reference_frames).
  bool new_reference = false;
  /// ICP of this frame against the model (not run for the first frame or known poses).
  bool icp_ran = false;
  IcpResult icp;
  /// The IMU's prediction dIMU of the motion since the previous frame that seeded ICP; without
  /// an IMU, T_a_b is the constant-velocity motion (TrackingConfig::constant_velocity_pairs) or the
  /// identity, and every other field is left at its default.
  MotionPrediction imu;
  InertialStatus inertial;
  IntegrationStats integration;  // when fused
  FrameTimings timings;
};

/// Not synchronized: call one Reconstructor from one thread at a time (it may move between
/// threads). Separate Reconstructors share no state (each has its own Vulkan instance and device)
/// and may run on separate threads at once.
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
  /// error but a status in the result. `depth` and `color` (image_view.hpp) are read during the
  /// call only; a DepthImage / ColorImage* converts.
  Result<FrameResult> track_and_fuse(double timestamp, const DepthView& depth,
                                     ColorInput color = nullptr,
                                     std::span<const ImuSample> imu = {});
  /// Fuses a frame at a known pose (ground truth or external tracking): no ICP, pose source
  /// `known`. IMU samples still feed the inertial estimators.
  Result<FrameResult> fuse_with_pose(double timestamp, const DepthView& depth, ColorInput color,
                                     const Eigen::Isometry3d& T_world_camera,
                                     std::span<const ImuSample> imu = {});

  /// Ends the scan after its last frame. A scan that ends while recovering holds a lost stretch
  /// whose end ICP placed but the hysteresis has not confirmed yet: it is settled as a broken
  /// recovery's is (see trajectory()), its kept frames placed backward from the recovering ones
  /// and the rest re-estimated. Returns the frames so placed; 0 and no change when no recovery is
  /// under way (a second call, a scan that ends tracking or lost). Frames may still follow: the
  /// recovery goes on counting, its stretch already settled.
  Result<std::size_t> finish();

  /// Writes the scan so far to `path`, atomically (a failed save leaves an existing file as it
  /// was): the configuration, the volume's blocks, the trajectory, and every estimate the next
  /// frames depend on (tracking state, IMU bias, gravity, velocity and mounting, a lost stretch
  /// under way with its kept depth). Frames fed to load()'s scanner then give exactly what they
  /// would have given here. Size and time: bench/README.md, "Saving and resuming a scan".
  Status save(const std::filesystem::path& path) const;
  /// The scan save() wrote, ready for its next frame (later than the last saved one), on the
  /// device `device` picks; the configuration is the saved one. Fails naming the file when it is
  /// missing, not a saved scan, of another format version, truncated or corrupt, and when the
  /// volume's pool cannot hold the saved blocks. extract_mesh_changes() starts with everything.
  static Result<Reconstructor> load(const std::filesystem::path& path,
                                    const DeviceOptions& device = {});

  /// Marching cubes over the allocated blocks (welded vertices, normals, colours).
  Result<Mesh> extract_mesh(const MeshOptions& options = {}) const;
  /// The mesh as pieces per block (extract_block_meshes() in mesh.hpp), only those that changed
  /// since the previous call: the blocks that fusion touched since then and their neighbours
  /// (whose cells read their voxels), and the blocks whose piece became empty. Everything on the
  /// first call, after reset() and when `options` change; nothing when nothing was fused. The
  /// pieces a viewer holds together hold extract_mesh()'s triangles. Downloads the hash table
  /// (12 bytes per slot) and the voxels of the changed blocks and their neighbours.
  Result<MeshUpdate> extract_mesh_changes(const MeshOptions& options = {});
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
  /// (ReconstructorConfig::smoothing.retrack_frames), the rest back to the last fully constrained
  /// frame from the error at the recovery and the errors of the frames so placed (their ICP poses
  /// against where dead reckoning put them; ReconstructorConfig::smoothing.retracked_frame_sigma):
  /// the conditional mean of dead reckoning's errors given those, under the navigator's sigmas when
  /// the loss began. With retracked_frame_sigma 0, the end is the oldest frame placed, its error
  /// measured from where dead reckoning put it before any move partial ICP made there. The rotation
  /// error is the gyro bias error (linear in time) plus the gyro's noise (a random walk); it tilts
  /// the gravity the accelerometer model removes (drift cubic in time), to which a velocity error
  /// (linear) and an accelerometer bias error (quadratic) add. Along the directions partial ICP
  /// fixed in a frame (the distance to a bare wall), the drift starts again from zero there; after
  /// a long loss, a frame's move along directions newly fixed measures the drift before it
  /// (ReconstructorConfig::smoothing.partial_move_sigma; drift_corrections in
  /// src/core/drift_model.hpp). Recovering frames that a later one disagreed with
  /// (FrameResult::recovery_restarted) belong to the stretch: they are re-estimated with it. A
  /// recovery that breaks (a recovering frame fails, the scan is lost again) ends the stretch
  /// before it the same way, at its recovering frames: they keep their ICP poses, from which the
  /// next lost frames are dead-reckoned. So does a scan that ends while recovering, at finish().
  /// FrameResult keeps the pose each frame had when it was tracked.
  const Trajectory& trajectory() const;
  const ReconstructorConfig& config() const;
  const DeviceInfo& device() const;
  /// The pyramid level ICP and the model raycast run at (ReconstructorConfig::tracking_level,
  /// resolved for the device).
  int tracking_level() const;
  /// Frames one model raycast serves as ICP's reference (ReconstructorConfig::reference_frames,
  /// resolved for the device).
  int reference_frames() const;
  /// Blocks of the TSDF volume that hold voxels, those its pool holds room for now (it grows as
  /// the scene needs, up to VolumeConfig::block_capacity), and how many times it grew.
  std::uint32_t allocated_blocks() const;
  std::uint32_t pool_blocks() const;
  std::uint32_t pool_growths() const;
  /// Device memory the TSDF volume reserves now (bytes, VolumeConfig::reserved_bytes).
  std::uint64_t memory_bytes() const;
  /// Mean march steps per ray of the volume's last raycast (after track_and_fuse(): the latest
  /// model raycast, FrameResult::new_reference), over the rays that marched; 0 before any. What
  /// bounds the raycast's time.
  Result<double> raycast_steps_per_ray() const;
  std::uint32_t validation_error_count() const;

 private:
  struct Impl;
  explicit Reconstructor(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imufusion
