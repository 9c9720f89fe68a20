#pragma once
// Reconstructor::Impl, the state behind the Reconstructor facade. Following a frame: the per-frame
// pipeline in reconstructor.cpp, its alignment in reconstructor_align.cpp, the relocalization
// search while lost in relocalization.cpp (RelocalizationDriver), the lost stretch's bookkeeping
// and correction in loss_recovery.cpp (LossRecovery); construction in reconstructor_create.cpp.

#include <deque>
#include <utility>

#include "core/state_archive.hpp"
#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu/volume.hpp"
#include "imufusion/reconstructor.hpp"
#include "scan/clock.hpp"
#include "scan/loss_recovery.hpp"
#include "scan/mesh_changes.hpp"
#include "scan/model_aligner.hpp"
#include "scan/relocalization.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"

namespace imufusion {

struct RaycastBuffers {
  gpu::Buffer vertices, normals, shaded, colors;

  static Result<RaycastBuffers> create(const std::shared_ptr<gpu::Context>& context,
                                       std::size_t pixels) {
    RaycastBuffers b;
    for (auto [buffer, bytes] :
         {std::pair{&b.vertices, pixels * 16}, std::pair{&b.normals, pixels * 16},
          std::pair{&b.shaded, pixels * 4}, std::pair{&b.colors, pixels * 4}}) {
      auto created = gpu::Buffer::create(context, bytes);
      if (!created) return created.error();
      *buffer = std::move(*created);
    }
    return b;
  }
};

inline Result<Vec4Image> download_map(const gpu::Buffer& buffer, int width, int height) {
  Vec4Image image;
  image.width = width;
  image.height = height;
  image.data.resize(static_cast<std::size_t>(width) * height);
  IMUFUSION_RETURN_IF_ERROR(
      buffer.download(image.data.data(), image.data.size() * sizeof(Eigen::Vector4f)));
  return image;
}

struct Reconstructor::Impl final : ModelAligner {
  ReconstructorConfig config;
  std::shared_ptr<gpu::Context> context;
  gpu::Preprocessor current;    // the incoming frame
  gpu::Preprocessor reference;  // the model raycast the next frame is aligned to
  gpu::CommandSequence preprocess_seq;
  // A fused frame's integration, the model raycast and its maps in `reference`'s pyramid.
  gpu::CommandSequence fuse_seq;
  gpu::CommandSequence icp_seq;
  gpu::IcpKernels icp_kernels;
  gpu::TsdfVolume volume;
  gpu::Buffer color;
  bool frame_has_color = false;      // the incoming frame came with a colour image
  bool reference_has_color = false;  // model.colors holds the reference's raycast colours
  double photometric_sigma = 0;      // gpu::PhotometricMaps::sigma, kept from frame to frame
  std::vector<std::uint32_t> rgba;
  RaycastBuffers model;
  MeshChangeTracker mesh_changes;  // what extract_mesh_changes() reported so far
  std::optional<InertialNavigator> navigator;
  TrackingStateMachine machine;
  PairingReference pairing;                      // what this scan's aligned frames pair
  PredictionCalibration prediction_calibration;  // how far the IMU's prediction is off on this scan

  Trajectory trajectory;
  RelocalizationDriver relocalization;  // the search for a lost frame's pose
  LossRecovery recovery;                // the stretch since the last fully constrained frame
  Eigen::Isometry3d T_world_reference = Eigen::Isometry3d::Identity();  // pose of the raycast
  bool has_reference = false;
  // The reference holds the scan's first frame's own maps (reference_from_first_frame), not a
  // model raycast.
  bool reference_is_frame = false;
  int reference_age = 0;         // frames tracked since the reference's raycast
  std::size_t fused_frames = 0;  // frames fused into the model (the first frame's included)
  int lost_run = 0;              // frames lost in a row up to the last one
  // The incoming frame's median depth (m), once median_depth computed it for that depth image.
  const void* median_depth_of = nullptr;
  double median_depth_value = 0;
  // The same for its mean depth-noise variance (m^2), which reliability() asks for each alignment.
  mutable const void* noise_variance_of = nullptr;
  mutable double noise_variance_value = 0;
  // The last tracked frame's seed gate moved a direction back to the prediction: the next
  // frame is gated at seed_gate_hold_sigmas.
  bool seed_gate_holding = false;
  double frame_interval = 0;  // s, from the previous frame to the one being aligned
  int tracking_level = 0;     // ReconstructorConfig::tracking_level resolved for the device
  int reference_frames = 1;   // ReconstructorConfig::reference_frames resolved for the device
  // Without the IMU (TrackingConfig::constant_velocity_pairs): the newest frames tracked in a
  // row, oldest first, at most constant_velocity_pairs + 1.
  std::deque<StampedPose> tracked_run;

  // The per-frame pipeline (reconstructor.cpp).
  Status check_frame(double timestamp, const DepthView& depth, const ColorView* rgb) const;
  Status preprocess(const DepthView& depth, const ColorView* rgb, FrameTimings& timings);
  Status finish_preprocess(FrameTimings& timings);
  Result<IntegrationStats> integrate(bool with_color, const Eigen::Isometry3d& T_world_camera,
                                     FrameTimings& timings);
  Status raycast_model(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                       std::pair<float, float> range, const RaycastBuffers& out,
                       std::vector<KernelTiming>* timings);
  Status submit_fuse_and_reference(const Eigen::Isometry3d& T_world_camera, bool fuse,
                                   bool with_color, FrameTimings& timings, bool keep_reference);
  Result<std::optional<IntegrationStats>> fuse_and_update_reference(
      const Eigen::Isometry3d& T_world_camera, bool fuse, bool with_color, FrameTimings& timings,
      bool keep_reference = false);
  bool reference_serves(const Eigen::Isometry3d& T_world_camera, const DepthView& depth);
  LossRecovery::Frame start_frame(const DepthView& depth, FrameResult& r);
  bool restart_due() const;
  Status restart();
  Status clear_model();
  Result<LossRecovery::Frame> track_frame(double timestamp, const DepthView& depth, FrameResult& r);
  void note_decision(const TrackingDecision& decision, const IcpResult& icp, bool was_lost,
                     const StampedPose& previous, double noise, FrameResult& r);
  Eigen::Isometry3d constant_velocity_motion(double interval) const;
  void note_motion(bool tracked, double timestamp, const Eigen::Isometry3d& T_world_camera);
  Status fuse_and_record(const TrackingDecision& decision, double timestamp, const DepthView& depth,
                         bool with_color, FrameResult& r);

  // The alignment of a frame (reconstructor_align.cpp).
  Status pair_with_own_model(FrameTimings& timings);
  Status reference_from_first_frame(FrameTimings& timings);
  std::size_t valid_depth_pixels(const DepthView& depth) const;
  double median_depth(const DepthView& depth);
  double noise_variance(const DepthView& depth) const;
  double tracking_image_motion(double rotation, double translation, double z) const;
  int seed_start_level(const MotionPrediction& prediction, const DepthView& depth);
  Result<IcpResult> align(const DepthView& depth, const Eigen::Isometry3d& T_world_seed,
                          const MotionPrediction& prediction, bool settling, FrameTimings& timings);

  // ModelAligner, for relocalization and loss recovery (reconstructor_align.cpp).
  Status load_frame(const DepthView& depth, FrameTimings& timings) override;
  Status set_reference(const Eigen::Isometry3d& T_world_camera, FrameTimings& timings) override;
  Result<Placement> place(const DepthView& depth, const Eigen::Isometry3d& T_world_seed,
                          FrameTimings& timings) override;
  IcpReliabilityThresholds reliability(const DepthView& depth) const override;
  Result<FramePoints> frame_points(int level) override;
  Result<HostVolume> model_snapshot() const override { return volume.snapshot(); }

  // Everything on the host the next frames depend on, but the configuration, the tracking level
  // and the volume (reconstructor_state.cpp).
  void describe_state(StateArchive& archive);
  Status restore_reference(const std::vector<float>& vertices, const std::vector<float>& normals,
                           const std::vector<std::uint32_t>& colors);

  InertialNavigator* navigator_or_null() { return navigator ? &*navigator : nullptr; }

  Status add_imu(std::span<const ImuSample> imu) {
    if (!config.imu.enabled || imu.empty()) return {};
    return navigator->add_samples(imu);
  }

  std::pair<float, float> depth_range() const {
    return {config.preprocess.min_depth, config.preprocess.max_depth};
  }

  // Whether a depth measurement (metres, 0 = none) is kept by preprocessing: within its range.
  bool valid_depth(double z) const {
    return z > 0 && z >= config.preprocess.min_depth && z <= config.preprocess.max_depth;
  }

  InertialStatus inertial_status() const {
    return navigator ? navigator->status() : InertialStatus{};
  }
};

}  // namespace imufusion
