// Reconstructor: one Vulkan context shared by preprocessing, ICP, fusion and raycast; the host
// runs Gauss-Newton, the IMU estimators and the tracking state machine.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "core/so3.hpp"
#include "gpu/rgba.hpp"
#include "scan/reconstructor_impl.hpp"

namespace imufusion {

Status Reconstructor::Impl::check_frame(double timestamp, const DepthView& depth,
                                        const ColorView* rgb) const {
  const Intrinsics& k = config.intrinsics;
  const auto at = [&](const Status& s) {
    return make_error(ErrorCode::kInvalidArgument, "at t=" + std::to_string(timestamp) + ": " +
                                                       s.error().message +
                                                       " (the reconstructor's intrinsics)");
  };
  if (Status s = depth.check(k.width, k.height); !s.ok()) return at(s);
  if (rgb != nullptr)
    if (Status s = rgb->check(k.width, k.height); !s.ok()) return at(s);
  if (!std::isfinite(timestamp))
    return make_error(ErrorCode::kInvalidArgument,
                      "frame timestamp " + std::to_string(timestamp) + " is not finite");
  if (!trajectory.empty() && !(timestamp > trajectory.back().timestamp))
    return make_error(ErrorCode::kInvalidArgument, "frame timestamp " + std::to_string(timestamp) +
                                                       " does not follow the previous frame's " +
                                                       std::to_string(trajectory.back().timestamp));
  return {};
}

// Uploads the frame and submits its preprocessing without waiting: the GPU work that follows on
// the queue sees its results, and finish_preprocess() collects its timings.
Status Reconstructor::Impl::preprocess(const DepthView& depth, const ColorView* rgb,
                                       FrameTimings& timings) {
  IMUFUSION_RETURN_IF_ERROR(finish_preprocess(timings));  // its buffers are written again here
  const auto t0 = Clock::now();
  // The colour is read by fusion, a later submission.
  if (rgb != nullptr)
    IMUFUSION_RETURN_IF_ERROR(gpu::upload_rgba(*rgb, color, rgba, &current.undistortion()));
  frame_has_color = rgb != nullptr;
  IMUFUSION_RETURN_IF_ERROR(current.submit(preprocess_seq, depth, tracking_level));
  timings.preprocess_ms += ms_since(t0);
  return {};
}

Status Reconstructor::Impl::finish_preprocess(FrameTimings& timings) {
  if (!preprocess_seq.pending()) return {};
  const auto t0 = Clock::now();
  auto t = preprocess_seq.wait();
  if (!t) return t.error();
  timings.kernels.insert(timings.kernels.end(), t->begin(), t->end());
  timings.preprocess_ms += ms_since(t0);
  return {};
}

Result<IntegrationStats> Reconstructor::Impl::integrate(bool with_color,
                                                        const Eigen::Isometry3d& T_world_camera,
                                                        FrameTimings& timings) {
  const auto t0 = Clock::now();
  auto stats = volume.integrate(current.raw_depth_metres(), with_color ? &color : nullptr,
                                config.intrinsics, T_world_camera, &timings.kernels);
  timings.integrate_ms += ms_since(t0);
  return stats;
}

Status Reconstructor::Impl::raycast_model(const Intrinsics& k,
                                          const Eigen::Isometry3d& T_world_camera,
                                          std::pair<float, float> range, const RaycastBuffers& out,
                                          std::vector<KernelTiming>* timings) {
  return volume.raycast(k, T_world_camera, range.first, range.second, out.vertices, out.normals,
                        out.shaded, out.colors, timings);
}

// Records the frame's fusion at T_world_camera (with `fuse`) and, unless `keep_reference`, the
// model raycast from there with the ICP reference maps from it, in one submission, and waits. The
// submission's wall time is split between integrate_ms and raycast_ms by their kernels' GPU times.
Status Reconstructor::Impl::submit_fuse_and_reference(const Eigen::Isometry3d& T_world_camera,
                                                      bool fuse, bool with_color,
                                                      FrameTimings& timings, bool keep_reference) {
  const auto t0 = Clock::now();
  const Intrinsics k = config.intrinsics.at_level(tracking_level);
  IMUFUSION_RETURN_IF_ERROR(fuse_seq.begin());
  Status recorded;
  if (fuse)
    recorded =
        volume.record_integrate(fuse_seq, current.raw_depth_metres(), with_color ? &color : nullptr,
                                config.intrinsics, T_world_camera);
  const std::size_t integrate_kernels = fuse ? gpu::TsdfVolume::kIntegrateDispatches : 0;
  if (recorded.ok() && !keep_reference)
    recorded = volume.record_raycast(fuse_seq, k, T_world_camera, depth_range().first,
                                     depth_range().second, model.vertices, model.normals,
                                     model.shaded, model.colors);
  if (recorded.ok() && !keep_reference)
    reference.record_maps_from(fuse_seq, model.vertices, model.normals, tracking_level);
  if (!keep_reference) {
    reference_has_color = recorded.ok();
    reference_is_frame = false;
  }
  auto t = fuse_seq.submit_and_wait();  // ends the recording also after a failed record
  IMUFUSION_RETURN_IF_ERROR(recorded);
  if (!t) return t.error();
  double integrate_gpu = 0, total_gpu = 0;
  for (std::size_t i = 0; i < t->size(); ++i) {
    total_gpu += (*t)[i].gpu_ms;
    if (i < integrate_kernels) integrate_gpu += (*t)[i].gpu_ms;
  }
  const double wall = ms_since(t0);
  const double integrate_share =
      total_gpu > 0 ? integrate_gpu / total_gpu : (fuse ? 0.5 : 0.0);  // no timestamps: halves
  timings.integrate_ms += wall * integrate_share;
  timings.raycast_ms += wall * (1 - integrate_share);
  timings.kernels.insert(timings.kernels.end(), t->begin(), t->end());
  return {};
}

// Whether the reference serves a tracked frame at T_world_camera as well (ReconstructorConfig::
// reference_frames): it is younger than reference_frames, the view moved less than
// reference_motion_pixels since it, at the frame's median depth, and the model it shows held at
// least reference_frames frames (each of a young model's frames changes it much).
bool Reconstructor::Impl::reference_serves(const Eigen::Isometry3d& T_world_camera,
                                           const DepthView& depth) {
  if (!has_reference || reference_age + 1 >= reference_frames) return false;
  const auto frames = static_cast<std::size_t>(reference_frames);
  if (fused_frames < frames + static_cast<std::size_t>(reference_age)) return false;
  const double z = median_depth(depth);
  if (z <= 0) return false;
  const Eigen::Isometry3d moved = T_world_reference.inverse() * T_world_camera;
  const double pixels = tracking_image_motion(Eigen::AngleAxisd(moved.linear()).angle(),
                                              moved.translation().norm(), z);
  return pixels < config.reference_motion_pixels;
}

// Fuses the frame at T_world_camera (with `fuse`) and makes the model seen from there the next
// frame's ICP reference, or with `keep_reference` keeps the one it has. A frame whose new blocks
// overflowed the pool fused nothing: the pool has grown, and the frame is fused and the reference
// raycast again.
Result<std::optional<IntegrationStats>> Reconstructor::Impl::fuse_and_update_reference(
    const Eigen::Isometry3d& T_world_camera, bool fuse, bool with_color, FrameTimings& timings,
    bool keep_reference) {
  keep_reference = keep_reference && has_reference;
  const int age = keep_reference ? reference_age + 1 : 0;
  for (;;) {
    IMUFUSION_RETURN_IF_ERROR(
        submit_fuse_and_reference(T_world_camera, fuse, with_color, timings, keep_reference));
    if (!keep_reference) T_world_reference = T_world_camera;
    reference_age = age;
    has_reference = true;
    if (!fuse) return std::optional<IntegrationStats>{};
    auto stats = volume.finish_integrate();
    if (!stats || stats->has_value()) return stats;
  }
}

// The mean motion over the frames tracked in a row before this one, scaled to `interval` (s);
// the identity with an IMU, with TrackingConfig::constant_velocity_pairs 0, or when the previous
// two frames were not both tracked.
Eigen::Isometry3d Reconstructor::Impl::constant_velocity_motion(double interval) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (navigator || tracked_run.size() < 2) return T;
  const StampedPose &first = tracked_run.front(), &last = tracked_run.back();
  const Eigen::Isometry3d motion = first.T_world_camera.inverse() * last.T_world_camera;
  const double scale = interval / (last.timestamp - first.timestamp);
  T.linear() = exp_so3(scale * log_so3(motion.linear()));
  T.translation() =
      scale * (last.T_world_camera.linear().transpose() *
               (last.T_world_camera.translation() - first.T_world_camera.translation()));
  return T;
}

void Reconstructor::Impl::note_motion(bool tracked, double timestamp,
                                      const Eigen::Isometry3d& T_world_camera) {
  if (!tracked || config.tracking.constant_velocity_pairs <= 0 ||
      (!tracked_run.empty() && timestamp <= tracked_run.back().timestamp)) {
    tracked_run.clear();
    return;
  }
  tracked_run.push_back({timestamp, T_world_camera});
  if (tracked_run.size() > static_cast<std::size_t>(config.tracking.constant_velocity_pairs) + 1)
    tracked_run.pop_front();
}

// The scan starts at its first frame with depth enough to track against; before it, the frame
// waits at the initial pose, lost, and the machine stays unstarted. A restarted scan starts at
// the last frame's pose.
LossRecovery::Frame Reconstructor::Impl::start_frame(const DepthView& depth, FrameResult& r) {
  LossRecovery::Frame f;
  f.index = r.index;
  f.timestamp = r.timestamp;
  if (valid_depth_pixels(depth) >= config.icp.reliability.min_inliers)
    f.decision = machine.start();
  else
    f.decision = {TrackingStatus::kLost, PoseSource::kInitial, false, 0, false};
  r.T_world_camera = trajectory.empty() ? config.initial_pose : trajectory.back().T_world_camera;
  return f;
}

// TrackingConfig::restart_lost_frames: the scan has been lost long enough, on a model of few
// enough frames, to start again.
bool Reconstructor::Impl::restart_due() const {
  const TrackingConfig& t = config.tracking;
  return t.restart_lost_frames > 0 && machine.started() && lost_run >= t.restart_lost_frames &&
         fused_frames <= static_cast<std::size_t>(t.restart_model_frames);
}

// The model and everything learnt from it dropped; the trajectory and the IMU's state kept.
Status Reconstructor::Impl::clear_model() {
  IMUFUSION_RETURN_IF_ERROR(volume.reset());
  machine.reset();
  pairing.reset();
  prediction_calibration.reset();
  has_reference = false;
  reference_is_frame = false;
  reference_has_color = false;
  photometric_sigma = 0;
  reference_age = 0;
  fused_frames = 0;
  lost_run = 0;
  seed_gate_holding = false;
  relocalization.reset();
  recovery.reset();
  T_world_reference = Eigen::Isometry3d::Identity();
  tracked_run.clear();
  return {};
}

// The scan starts again at the incoming frame (TrackingConfig::restart_lost_frames).
Status Reconstructor::Impl::restart() {
  IMUFUSION_RETURN_IF_ERROR(clear_model());
  if (navigator) navigator->forget_velocity();
  return {};
}

// The frame aligned from the predicted seed (relocalized while lost), a recovery it restarts and
// the state machine's decision. Sets r's prediction, ICP result and pose; returns the frame as
// loss recovery sees it.
Result<LossRecovery::Frame> Reconstructor::Impl::track_frame(double timestamp,
                                                             const DepthView& depth,
                                                             FrameResult& r) {
  const StampedPose& previous = trajectory.back();
  frame_interval = timestamp - previous.timestamp;
  if (navigator)
    r.imu = navigator->predict(previous.timestamp, timestamp);
  else
    r.imu.T_a_b = constant_velocity_motion(frame_interval);
  LossRecovery::Frame f;
  f.index = r.index;
  f.timestamp = timestamp;
  f.T_world_seed = previous.T_world_camera * r.imu.T_a_b;
  auto icp = align(depth, f.T_world_seed, r.imu, machine.recovering_or_lost(), r.timings);
  if (!icp) return icp.error();
  const Eigen::Matrix3d R_world_reference = T_world_reference.linear();
  Eigen::Isometry3d T_world_icp = T_world_reference * icp->T_ref_cur;
  f.T_world_estimate = icp->partial() ? T_world_icp : f.T_world_seed;
  f.was_lost = machine.status() == TrackingStatus::kLost;
  const RelocalizationDriver::Frame search_frame{
      .timestamp = timestamp,
      .lost = f.was_lost,
      .rotation_from_imu = r.imu.rotation_from_imu,
      .icp_reliable = icp->reliable(),
      .partial_directions = icp->partial_directions(),
      .T_world_estimate = f.T_world_estimate,
      .constrained_time = recovery.constrained_time(),
      .lost_at = trajectory[recovery.constrained_index()].T_world_camera.translation()};
  auto searched = relocalization.on_frame(search_frame, depth, *this, r.timings);
  if (!searched) return searched.error();
  f.long_loss = searched->long_loss;
  if (searched->found) {
    icp = searched->found->icp;
    T_world_icp = searched->found->T_world_camera;
    r.relocalized = true;
  } else if (f.long_loss && icp->reliable()) {
    icp->verdict = IcpVerdict::kUnreliable;
    icp->reason = "after a long loss, not confirmed as the only fit by the relocalization search";
  }
  const bool partial_may_fuse =
      timestamp - recovery.constrained_time() <= config.imu.max_partial_seconds;
  if (icp->partial() && !partial_may_fuse && !machine.recovering_or_lost()) {
    char limit[32];
    std::snprintf(limit, sizeof limit, "%.3g", config.imu.max_partial_seconds);
    icp->reason += std::string("; partial for more than ") + limit + " s";
  }
  r.icp_ran = true;
  r.icp = *icp;
  f.restarted = r.recovery_restarted =
      recovery.disagrees(machine.status(), *icp, r.imu, f.T_world_seed, T_world_icp);
  if (f.restarted) machine.restart_recovery();
  f.decision = machine.step(icp->reliable(), icp->quality.converged, icp->partial(),
                            partial_may_fuse, r.relocalized);
  const PoseSource source = f.decision.source;
  r.T_world_camera = source == PoseSource::kIcp || source == PoseSource::kIcpPartial
                         ? T_world_icp
                         : f.T_world_seed;
  f.fixed.noalias() = R_world_reference * icp->fixed_translation * R_world_reference.transpose();
  f.directions = icp->partial_directions();
  note_decision(f.decision, *icp, f.was_lost, previous, noise_variance(depth), r);
  return f;
}

// What a tracked frame's decision teaches the scan: the pairing reference (the frame's mean
// depth-noise variance `noise`, m^2) and the prediction's calibration, the seed gate, and the
// motion the navigator observes.
void Reconstructor::Impl::note_decision(const TrackingDecision& decision, const IcpResult& icp,
                                        bool was_lost, const StampedPose& previous, double noise,
                                        FrameResult& r) {
  // A frame accepted for its agreement with the IMU paired less than the reference asks for; a
  // frame aligned to the first frame's own maps paired more than a model raycast offers.
  if (decision.status == TrackingStatus::kTracking && decision.source == PoseSource::kIcp &&
      !icp.quality.agreed_with_seed && !reference_is_frame) {
    pairing.add(icp.quality.inlier_fraction, icp.quality.pixel_fraction);
    pairing.add_residual(icp.quality.residual_per_weight, noise);
    // Only against a whole prediction: the first frames' translation sigma is a bound.
    if (icp.quality.seed_chi2 > 0 && icp.quality.seed_gated_directions == 0 &&
        r.imu.translation_predicted)
      prediction_calibration.add(icp.quality.seed_chi2);
  }
  seed_gate_holding =
      decision.status == TrackingStatus::kTracking && icp.quality.seed_gated_directions > 0;
  // A pair measures the motion only when both poses came from ICP against the same model:
  // the first frame placed after a loss (relocalized or not) also undoes dead reckoning's
  // drift, and a restarted recovery's frame undoes a wrong fit.
  if (navigator) {
    navigator->observe(previous.timestamp, r.timestamp, previous.T_world_camera, r.T_world_camera,
                       decision.source == PoseSource::kIcp && !was_lost && !r.recovery_restarted);
    if (r.recovery_restarted) navigator->forget_velocity();
  }
}

// Fuses the frame at its pose, makes the model seen from there the next reference and appends
// the frame to the trajectory.
Status Reconstructor::Impl::fuse_and_record(const TrackingDecision& decision, double timestamp,
                                            const DepthView& depth, bool with_color,
                                            FrameResult& r) {
  r.status = decision.status;
  r.source = decision.source;
  r.recovered = decision.recovered;
  const bool keep = decision.status == TrackingStatus::kTracking &&
                    decision.source == PoseSource::kIcp && decision.fuse &&
                    reference_serves(r.T_world_camera, depth);
  auto stats =
      fuse_and_update_reference(r.T_world_camera, decision.fuse, with_color, r.timings, keep);
  if (!stats) return stats.error();
  r.new_reference = reference_age == 0;
  if (*stats) {
    r.integration = **stats;
    r.fused = true;
    ++fused_frames;
    relocalization.model_changed();
    relocalization.note_view(r.T_world_camera.linear());
  }
  if (decision.source == PoseSource::kInitial && decision.fuse) {
    IMUFUSION_RETURN_IF_ERROR(pair_with_own_model(r.timings));
    IMUFUSION_RETURN_IF_ERROR(reference_from_first_frame(r.timings));
  }
  trajectory.push_back({timestamp, r.T_world_camera});
  return {};
}

// The per-frame pipeline: preprocessing, tracking (alignment, relocalization while lost, the state
// machine's decision), fusion and the model raycast for the next frame, then loss recovery's
// bookkeeping and the correction of a lost stretch the frame ends.
Result<FrameResult> Reconstructor::track_and_fuse(double timestamp, const DepthView& depth,
                                                  ColorInput color_input,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const ColorView* color = color_input.get();
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  m.median_depth_of = m.noise_variance_of = nullptr;  // a new frame, perhaps in the last's buffer
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));
  const bool restarting = m.restart_due();
  if (restarting) IMUFUSION_RETURN_IF_ERROR(m.restart());
  auto frame = m.machine.started() && m.has_reference ? m.track_frame(timestamp, depth, r)
                                                      : m.start_frame(depth, r);
  if (!frame) return frame.error();
  r.restarted = restarting && m.machine.started();
  const TrackingDecision& decision = frame->decision;
  m.lost_run = decision.status == TrackingStatus::kLost ? m.lost_run + 1 : 0;
  // The pose is a measurement of the motion: the scan's start, or fully tracked by ICP.
  m.note_motion(
      decision.status == TrackingStatus::kTracking &&
          (decision.source == PoseSource::kIcp || decision.source == PoseSource::kInitial),
      timestamp, r.T_world_camera);
  IMUFUSION_RETURN_IF_ERROR(m.fuse_and_record(decision, timestamp, depth, color != nullptr, r));
  frame->T_world_camera = r.T_world_camera;
  auto retracked =
      m.recovery.on_frame(*frame, depth, m.navigator_or_null(), m.trajectory, m, r.timings);
  if (!retracked) return retracked.error();
  r.retracked = *retracked;
  IMUFUSION_RETURN_IF_ERROR(m.finish_preprocess(r.timings));
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

Result<FrameResult> Reconstructor::fuse_with_pose(double timestamp, const DepthView& depth,
                                                  ColorInput color_input,
                                                  const Eigen::Isometry3d& T_world_camera,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const ColorView* color = color_input.get();
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  if (!T_world_camera.matrix().allFinite())
    return make_error(ErrorCode::kInvalidArgument,
                      "known pose at t=" + std::to_string(timestamp) + " is not finite");
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  r.T_world_camera = T_world_camera;
  r.status = TrackingStatus::kTracking;
  r.source = PoseSource::kKnown;
  m.recovery.on_known_pose(r.index, timestamp, m.navigator_or_null());
  if (!m.trajectory.empty() && m.navigator) {
    const StampedPose& previous = m.trajectory.back();
    r.imu = m.navigator->predict(previous.timestamp, timestamp);
    m.navigator->observe(previous.timestamp, timestamp, previous.T_world_camera, T_world_camera,
                         true);
  }
  if (!m.machine.started()) m.machine.start();
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));
  auto stats = m.integrate(color != nullptr, T_world_camera, r.timings);
  if (!stats) return stats.error();
  IMUFUSION_RETURN_IF_ERROR(m.finish_preprocess(r.timings));
  r.integration = *stats;
  r.fused = true;
  m.relocalization.model_changed();
  m.relocalization.note_view(T_world_camera.linear());
  m.trajectory.push_back({timestamp, T_world_camera});
  m.note_motion(true, timestamp, T_world_camera);
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

// A correction is pending from a loss's first recovering frame until the recovery completes or
// breaks: here, the scan ends while recovering.
Result<std::size_t> Reconstructor::finish() {
  FrameTimings timings;  // of no frame
  return impl_->recovery.settle(impl_->trajectory, *impl_, timings);
}

Result<Mesh> Reconstructor::extract_mesh(const MeshOptions& options) const {
  auto volume = snapshot();
  if (!volume) return volume.error();
  return imufusion::extract_mesh(*volume, options);
}

Result<RaycastImages> Reconstructor::raycast(const Eigen::Isometry3d& T_world_camera,
                                             std::optional<Intrinsics> intrinsics,
                                             std::optional<std::pair<float, float>> depth_range) {
  Impl& m = *impl_;
  const Intrinsics k = intrinsics.value_or(m.config.intrinsics);
  const auto range = depth_range.value_or(m.depth_range());
  if (!(range.first >= 0 && range.second > range.first))
    return make_error(ErrorCode::kInvalidArgument, "raycast depth range is empty");
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  if (k.width <= 0 || k.height <= 0)
    return make_error(ErrorCode::kInvalidArgument, "raycast of an empty image");
  auto buffers = RaycastBuffers::create(m.context, pixels);
  if (!buffers) return buffers.error();
  IMUFUSION_RETURN_IF_ERROR(m.raycast_model(k, T_world_camera, range, *buffers, nullptr));
  RaycastImages out;
  auto vertices = download_map(buffers->vertices, k.width, k.height);
  if (!vertices) return vertices.error();
  auto normals = download_map(buffers->normals, k.width, k.height);
  if (!normals) return normals.error();
  auto shaded = buffers->shaded.download_as<std::uint32_t>(pixels);
  if (!shaded) return shaded.error();
  auto colors = buffers->colors.download_as<std::uint32_t>(pixels);
  if (!colors) return colors.error();
  out.vertices = std::move(*vertices);
  out.normals = std::move(*normals);
  out.shaded = gpu::unpack_rgba(*shaded, k.width, k.height);
  out.color = gpu::unpack_rgba(*colors, k.width, k.height);
  return out;
}

Result<HostVolume> Reconstructor::snapshot() const { return impl_->volume.snapshot(); }

Status Reconstructor::reset() {
  Impl& m = *impl_;
  IMUFUSION_RETURN_IF_ERROR(m.clear_model());
  if (m.navigator) m.navigator->reset();
  m.trajectory.clear();
  return {};
}

const Trajectory& Reconstructor::trajectory() const { return impl_->trajectory; }
const ReconstructorConfig& Reconstructor::config() const { return impl_->config; }
const DeviceInfo& Reconstructor::device() const { return impl_->context->info(); }
int Reconstructor::tracking_level() const { return impl_->tracking_level; }
int Reconstructor::reference_frames() const { return impl_->reference_frames; }
std::uint32_t Reconstructor::allocated_blocks() const { return impl_->volume.allocated_blocks(); }
std::uint32_t Reconstructor::pool_blocks() const { return impl_->volume.pool_blocks(); }
std::uint32_t Reconstructor::pool_growths() const { return impl_->volume.pool_growths(); }

Result<double> Reconstructor::raycast_steps_per_ray() const {
  auto steps = impl_->volume.last_raycast_steps();
  if (!steps) return steps.error();
  std::uint64_t total = 0, marched = 0;
  for (const std::uint32_t n : *steps) {
    total += n;
    marched += n > 0 ? 1 : 0;
  }
  return marched == 0 ? 0.0 : static_cast<double>(total) / static_cast<double>(marched);
}
std::uint64_t Reconstructor::memory_bytes() const { return impl_->volume.reserved_bytes(); }
std::uint32_t Reconstructor::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion
