#pragma once
// Reconstructor::Impl, the state behind the Reconstructor facade: the per-frame pipeline is in
// reconstructor.cpp, the alignment of a frame in reconstructor_align.cpp, relocalization and the
// lost-stretch correction in reconstructor_recovery.cpp.

#include <algorithm>
#include <chrono>
#include <deque>
#include <utility>

#include "core/drift_model.hpp"
#include "core/relocalizer.hpp"
#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu/volume.hpp"
#include "imufusion/reconstructor.hpp"
#include "vk/command_sequence.hpp"
#include "vk/context.hpp"

namespace imufusion {

// Shared by the reconstructor's .cpp files.
using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

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

struct Reconstructor::Impl {
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
  std::vector<std::uint32_t> rgba;
  RaycastBuffers model;
  std::optional<InertialNavigator> navigator;
  TrackingStateMachine machine;
  PairingReference pairing;                      // what this scan's aligned frames pair
  PredictionCalibration prediction_calibration;  // how far the IMU's prediction is off on this scan

  Trajectory trajectory;
  double last_constrained_time = 0;  // s: the last frame whose pose ICP fixed in all directions
  std::size_t last_constrained_index = 0;  // its index in the trajectory

  // Relocalization: the model's distance field, built at the first attempt after the model last
  // changed, and the lost frames since the last attempt.
  SurfaceDistanceField field;
  bool field_current = false;
  int lost_frames_since_attempt = 0;
  struct Relocalization {
    IcpResult icp;
    Eigen::Isometry3d T_world_camera;
  };
  // A frame partial ICP placed since the last fully constrained one.
  struct PartialFrame {
    std::size_t index = 0;
    Eigen::Matrix3d fixed;  // world translation directions partial ICP fixed
    Eigen::Vector3d moved;  // the frame's move from its dead-reckoned seed (world)
    bool measured = false;  // after a long loss: the move is a measurement, not exact
  };
  // Frame `index`'s entry in `frames` (sorted by index), or nullptr when partial ICP did not place
  // it.
  static const PartialFrame* find_partial(const std::vector<PartialFrame>& frames,
                                          std::size_t index) {
    const auto it =
        std::lower_bound(frames.begin(), frames.end(), index,
                         [](const PartialFrame& f, std::size_t i) { return f.index < i; });
    return it != frames.end() && it->index == index ? &*it : nullptr;
  }
  // The first frame that ICP placed after a loss, and where dead reckoning had put it: once the
  // recovery is confirmed, the lost stretch back to `anchor` is corrected by the difference.
  struct PendingCorrection {
    std::size_t anchor = 0, index = 0;
    Eigen::Isometry3d estimate, corrected;
    DriftPrior prior;
    std::vector<PartialFrame> fixed;
    std::deque<std::pair<std::size_t, DepthImage>> depth;  // the lost frames kept (see lost_depth)
  };
  std::optional<PendingCorrection> pending;
  // The frames since the last fully constrained one that partial ICP placed, with the world
  // translation directions it fixed and, after a long loss, its moves.
  std::vector<PartialFrame> partial_fixed;
  DriftPrior constrained_prior;  // the inertial estimates at the last fully constrained frame
  // The depth of the newest frames since the last fully constrained one (dead-reckoned or
  // partial), at most config.smoothing.retrack_frames: a recovery places them backward.
  std::deque<std::pair<std::size_t, DepthImage>> lost_depth;
  Eigen::Isometry3d T_world_reference = Eigen::Isometry3d::Identity();  // pose of the raycast
  bool has_reference = false;
  // The last tracked frame's seed gate moved a direction back to the prediction: the next
  // frame is gated at seed_gate_hold_sigmas.
  bool seed_gate_holding = false;
  double frame_interval = 0;  // s, from the previous frame to the one being aligned
  int tracking_level = 0;     // ReconstructorConfig::tracking_level resolved for the device
  // Without the IMU (TrackingConfig::constant_velocity_pairs): the newest frames tracked in a
  // row, oldest first, at most constant_velocity_pairs + 1.
  std::deque<StampedPose> tracked_run;

  // The per-frame pipeline (reconstructor.cpp).
  Status check_frame(double timestamp, const DepthImage& depth, const ColorImage* rgb) const;
  Status preprocess(const DepthImage& depth, const ColorImage* rgb, FrameTimings& timings);
  Status finish_preprocess(FrameTimings& timings);
  Result<IntegrationStats> integrate(bool with_color, const Eigen::Isometry3d& T_world_camera,
                                     FrameTimings& timings);
  Status raycast_model(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                       std::pair<float, float> range, const RaycastBuffers& out,
                       std::vector<KernelTiming>* timings);
  Result<std::optional<IntegrationStats>> fuse_and_update_reference(
      const Eigen::Isometry3d& T_world_camera, bool fuse, bool with_color, FrameTimings& timings);
  Status update_reference(const Eigen::Isometry3d& T_world_camera, FrameTimings& timings);
  Status pair_with_own_model(FrameTimings& timings);
  std::size_t valid_depth_pixels(const DepthImage& depth) const;
  IcpReliabilityThresholds reliability(const DepthImage& depth) const;
  int seed_start_level(const MotionPrediction& prediction, const DepthImage& depth) const;
  Result<IcpResult> align(const DepthImage& depth, const Eigen::Isometry3d& T_world_seed,
                          const MotionPrediction& prediction, bool settling, FrameTimings& timings);
  Result<TrackingDecision> track_frame(double timestamp, const DepthImage& depth, FrameResult& r);
  Eigen::Isometry3d constant_velocity_motion(double interval) const;
  void note_motion(bool tracked, double timestamp, const Eigen::Isometry3d& T_world_camera);
  void update_stretch(const TrackingDecision& decision, double timestamp, std::size_t index,
                      const DepthImage& depth);
  Status fuse_and_record(const TrackingDecision& decision, double timestamp, bool with_color,
                         FrameResult& r);

  Status add_imu(std::span<const ImuSample> imu) {
    if (!config.imu.enabled || imu.empty()) return {};
    return navigator->add_samples(imu);
  }

  std::pair<float, float> depth_range() const {
    return {config.preprocess.min_depth, config.preprocess.max_depth};
  }

  // Whether a raw depth measurement is kept by preprocessing: measured and within its range.
  bool valid_depth(std::uint16_t raw, double z) const {
    return raw != 0 && z >= config.preprocess.min_depth && z <= config.preprocess.max_depth;
  }

  InertialStatus inertial_status() const {
    return navigator ? navigator->status() : InertialStatus{};
  }

  // Relocalization and the lost-stretch correction (reconstructor_recovery.cpp).
  double drift_radius(double timestamp) const;
  bool long_loss(double timestamp, const MotionPrediction& prediction) const;
  bool may_relocalize(const IcpResult& icp, const MotionPrediction& prediction, bool long_loss);
  Status build_field();
  Result<std::optional<Relocalization>> relocalize(const DepthImage& depth,
                                                   const Eigen::Isometry3d& T_world_estimate,
                                                   double timestamp, FrameTimings& timings);

  // What retrack() returns (see there).
  struct Retracked {
    PendingCorrection correction;
    std::vector<std::pair<std::size_t, Eigen::Isometry3d>> placed;
    bool moved_reference = false;
  };
  Result<Retracked> retrack(const PendingCorrection& c);
  void keep_depth(std::deque<std::pair<std::size_t, DepthImage>>& kept, std::size_t index,
                  const DepthImage& depth) const;
  bool disagrees_with_recovery(const IcpResult& icp, const FrameResult& r,
                               const Eigen::Isometry3d& T_world_seed,
                               const Eigen::Isometry3d& T_world_icp) const;
  void restart_pending(std::size_t index, const Eigen::Isometry3d& T_world_seed,
                       const Eigen::Isometry3d& T_world_icp);
  Status settle_lost_stretch(const PendingCorrection& c, FrameResult& r);
  void correct_lost_stretch(const PendingCorrection& c,
                            const std::vector<std::pair<std::size_t, Eigen::Isometry3d>>& placed);
  std::optional<Eigen::Vector3d> stretch_end_velocity_error(const PendingCorrection& c,
                                                            double end_time) const;
  static StretchCorrection end_error(const PendingCorrection& c);
  std::vector<StretchFrame> stretch_frames(
      const PendingCorrection& c,
      const std::vector<std::pair<std::size_t, Eigen::Isometry3d>>& placed) const;
  DriftPrior drift_prior() const;
};

}  // namespace imufusion
