// Reconstructor: one Vulkan context shared by preprocessing, ICP, fusion and raycast; the host
// runs Gauss-Newton, the IMU estimators and the tracking state machine.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <deque>
#include <limits>
#include <string>
#include <utility>

#include "core/inertial_internal.hpp"
#include "core/relocalizer.hpp"
#include "gpu/command_sequence.hpp"
#include "gpu/context.hpp"
#include "gpu/icp_kernels.hpp"
#include "gpu/preprocessor.hpp"
#include "gpu/rgba.hpp"
#include "gpu/volume.hpp"
#include "imufusion/reconstructor.hpp"

namespace imufusion {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct RaycastBuffers {
  gpu::Buffer vertices, normals, shaded, colors;

  static Result<RaycastBuffers> create(const std::shared_ptr<gpu::Context>& context, std::size_t pixels) {
    RaycastBuffers b;
    for (auto [buffer, bytes] : {std::pair{&b.vertices, pixels * 16}, std::pair{&b.normals, pixels * 16},
                                 std::pair{&b.shaded, pixels * 4}, std::pair{&b.colors, pixels * 4}}) {
      auto created = gpu::Buffer::create(context, bytes);
      if (!created) return created.error();
      *buffer = std::move(*created);
    }
    return b;
  }
};

Result<Vec4Image> download_map(const gpu::Buffer& buffer, int width, int height) {
  Vec4Image image;
  image.width = width;
  image.height = height;
  image.data.resize(static_cast<std::size_t>(width) * height);
  IMUFUSION_RETURN_IF_ERROR(buffer.download(image.data.data(), image.data.size() * sizeof(Eigen::Vector4f)));
  return image;
}

}  // namespace

struct Reconstructor::Impl {
  ReconstructorConfig config;
  std::shared_ptr<gpu::Context> context;
  gpu::Preprocessor current;    // the incoming frame
  gpu::Preprocessor reference;  // the model raycast the next frame is aligned to
  gpu::CommandSequence preprocess_seq;
  gpu::CommandSequence icp_seq;
  gpu::IcpKernels icp_kernels;
  gpu::TsdfVolume volume;
  gpu::Buffer color;
  std::vector<std::uint32_t> rgba;
  RaycastBuffers model;
  std::optional<InertialNavigator> navigator;
  TrackingStateMachine machine;
  PairingReference pairing;  // what this scan's aligned frames pair

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
  // Frame `index`'s entry in `frames` (sorted by index), or nullptr when partial ICP did not place it.
  static const PartialFrame* find_partial(const std::vector<PartialFrame>& frames, std::size_t index) {
    const auto it = std::lower_bound(frames.begin(), frames.end(), index,
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
  // partial), at most config.retrack_lost_frames: a recovery places them backward.
  std::deque<std::pair<std::size_t, DepthImage>> lost_depth;
  Eigen::Isometry3d T_world_reference = Eigen::Isometry3d::Identity();  // pose of the raycast
  bool has_reference = false;
  // The last tracked frame's seed gate moved a direction back to the prediction: the next
  // frame is gated at seed_gate_hold_sigmas.
  bool seed_gate_holding = false;

  Status check_frame(double timestamp, const DepthImage& depth, const ColorImage* rgb) const {
    const Intrinsics& k = config.intrinsics;
    if (depth.width != k.width || depth.height != k.height ||
        depth.data.size() != static_cast<std::size_t>(k.width) * k.height)
      return make_error(ErrorCode::kInvalidArgument,
                        "depth frame at t=" + std::to_string(timestamp) + " is " + std::to_string(depth.width) +
                            "x" + std::to_string(depth.height) + ", the reconstructor was made for " +
                            std::to_string(k.width) + "x" + std::to_string(k.height));
    if (rgb != nullptr && (rgb->width != depth.width || rgb->height != depth.height ||
                           rgb->data.size() != depth.data.size() * 3))
      return make_error(ErrorCode::kInvalidArgument,
                        "colour frame at t=" + std::to_string(timestamp) + " is " + std::to_string(rgb->width) +
                            "x" + std::to_string(rgb->height) + ", the depth frame " +
                            std::to_string(depth.width) + "x" + std::to_string(depth.height));
    if (!std::isfinite(timestamp))
      return make_error(ErrorCode::kInvalidArgument, "frame timestamp " + std::to_string(timestamp) + " is not finite");
    if (!trajectory.empty() && !(timestamp > trajectory.back().timestamp))
      return make_error(ErrorCode::kInvalidArgument,
                        "frame timestamp " + std::to_string(timestamp) + " does not follow the previous frame's " +
                            std::to_string(trajectory.back().timestamp));
    return {};
  }

  Status add_imu(std::span<const ImuSample> imu) {
    if (!config.use_imu || imu.empty()) return {};
    return navigator->add_samples(imu);
  }

  Status preprocess(const DepthImage& depth, const ColorImage* rgb, FrameTimings& timings) {
    const auto t0 = Clock::now();
    IMUFUSION_RETURN_IF_ERROR(current.upload(depth));
    IMUFUSION_RETURN_IF_ERROR(preprocess_seq.begin());
    current.record(preprocess_seq);
    auto t = preprocess_seq.submit_and_wait();
    if (!t) return t.error();
    timings.kernels.insert(timings.kernels.end(), t->begin(), t->end());
    if (rgb != nullptr) {
      gpu::pack_rgba(*rgb, rgba);
      IMUFUSION_RETURN_IF_ERROR(color.upload(rgba.data(), rgba.size() * 4));
    }
    timings.preprocess_ms = ms_since(t0);
    return {};
  }

  Result<IntegrationStats> integrate(bool with_color, const Eigen::Isometry3d& T_world_camera,
                                     FrameTimings& timings) {
    const auto t0 = Clock::now();
    auto stats = volume.integrate(current.raw_depth_metres(), with_color ? &color : nullptr,
                                  config.intrinsics, T_world_camera, &timings.kernels);
    timings.integrate_ms = ms_since(t0);
    return stats;
  }

  Status raycast_model(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                       std::pair<float, float> range, const RaycastBuffers& out,
                       std::vector<KernelTiming>* timings) {
    return volume.raycast(k, T_world_camera, range.first, range.second, out.vertices, out.normals,
                          out.shaded, out.colors, timings);
  }

  std::pair<float, float> depth_range() const {
    return {config.preprocess.min_depth, config.preprocess.max_depth};
  }

  // The model seen from the frame's final pose becomes the next frame's ICP reference.
  Status update_reference(const Eigen::Isometry3d& T_world_camera, FrameTimings& timings) {
    const auto t0 = Clock::now();
    const Intrinsics& k = config.intrinsics;
    IMUFUSION_RETURN_IF_ERROR(raycast_model(k, T_world_camera, depth_range(), model, &timings.kernels));
    auto vertices = download_map(model.vertices, k.width, k.height);
    if (!vertices) return vertices.error();
    auto normals = download_map(model.normals, k.width, k.height);
    if (!normals) return normals.error();
    IMUFUSION_RETURN_IF_ERROR(reference.upload_maps(*vertices, *normals));
    T_world_reference = T_world_camera;
    has_reference = true;
    timings.raycast_ms += ms_since(t0);
    return {};
  }

  // The first frame against the model it alone made, at its own pose: what an aligned frame of
  // this sensor and scene pairs, the pairing reference until tracked frames replace it.
  Status pair_with_own_model(FrameTimings& timings) {
    gpu::GpuNormalEquationSource source(icp_kernels, icp_seq, current, reference, &timings.kernels);
    const float min_cos = static_cast<float>(std::cos(config.icp.max_normal_angle_deg[0] * M_PI / 180.0));
    auto eq = source.evaluate(0, Eigen::Isometry3d::Identity(), config.icp.max_distance[0], min_cos);
    if (!eq) return eq.error();
    if (eq->valid_pixels > 0 && eq->valid_information > 0) pairing.add(eq->inlier_fraction(), eq->pixel_fraction());
    return {};
  }

  // Whether a raw depth measurement is kept by preprocessing: measured and within its range.
  bool valid_depth(std::uint16_t raw, double z) const {
    return raw != 0 && z >= config.preprocess.min_depth && z <= config.preprocess.max_depth;
  }

  std::size_t valid_depth_pixels(const DepthImage& depth) const {
    const double scale = 1.0 / depth.depth_scale;
    return static_cast<std::size_t>(std::count_if(depth.data.begin(), depth.data.end(),
                                                  [&](std::uint16_t raw) { return valid_depth(raw, raw * scale); }));
  }

  // Mean sigma(z)^2 over the frame's valid depths (m^2).
  double mean_noise_variance(const DepthImage& depth) const {
    double sum = 0;
    std::size_t n = 0;
    const double scale = 1.0 / depth.depth_scale;
    for (std::uint16_t raw : depth.data) {
      const double z = raw * scale;
      if (!valid_depth(raw, z)) continue;
      const double sigma = config.icp.depth_noise.sigma(z);
      sum += sigma * sigma;
      ++n;
    }
    return n > 0 ? sum / static_cast<double>(n) : 0.0;
  }

  // The reliability thresholds for this frame: the residual test widened to its depth noise,
  // the pairing tests lowered to what this scan's aligned frames pair.
  IcpReliabilityThresholds reliability(const DepthImage& depth) const {
    IcpReliabilityThresholds t = config.icp.reliability;
    t.max_residual_per_weight = std::max(t.max_residual_per_weight, 2.0 * mean_noise_variance(depth));
    pairing.apply(t.min_inlier_fraction, t.min_pixel_fraction);
    return t;
  }

  // ICP of the current frame against the reference from a seed; `settling`: the budget and
  // convergence thresholds of a frame that must first settle onto the model (lost or
  // recovering).
  Result<IcpResult> align(const DepthImage& depth, const Eigen::Isometry3d& T_world_seed,
                          const MotionPrediction& prediction, bool settling, FrameTimings& timings) {
    const auto t0 = Clock::now();
    IcpConfig icp = config.icp;
    icp.keep_seed_in_degenerate_directions =
        config.partial_icp_with_imu && prediction.rotation_from_imu && prediction.translation_predicted;
    icp.reliability = reliability(depth);
    // The seed gate, while tracking on an inertial prediction: a lost or recovering frame's
    // seed carries the whole drift of dead reckoning, not one frame's prediction error, and a
    // velocity from one or two tracked pairs carries their error into the seed.
    if (config.seed_gate_with_imu && icp.keep_seed_in_degenerate_directions && !settling &&
        prediction.translation_inertial) {
      icp.seed_sigma_rotation = prediction.rotation_sigma;
      icp.seed_sigma_translation = prediction.translation_sigma;
      if (seed_gate_holding) icp.seed_gate_sigmas = icp.seed_gate_hold_sigmas;
    }
    // An inertial seed while tracking is millimetres off, within the finest level's reach: the
    // few iterations allowed are all spent at full resolution.
    if (config.imu_seed_finest_level_only && prediction.rotation_from_imu && !settling)
      std::fill(icp.iterations_per_level.begin() + 1, icp.iterations_per_level.end(), 0);
    if (settling) {
      icp.max_total_iterations = std::max(icp.max_total_iterations, config.tracking.recovery_icp_iterations);
      icp.converged_rotation = std::max(icp.converged_rotation, config.recovery_converged_rotation);
      icp.converged_translation = std::max(icp.converged_translation, config.recovery_converged_translation);
    }
    gpu::GpuNormalEquationSource source(icp_kernels, icp_seq, current, reference, &timings.kernels);
    auto result = run_icp(source, icp, T_world_reference.inverse() * T_world_seed);
    timings.icp_ms += ms_since(t0);
    return result;
  }

  // How far dead reckoning may have drifted since the last fully constrained frame (m), from
  // the coarsest ICP level's reach up to relocalization_max_radius.
  double drift_radius(double timestamp) const {
    const double lost_seconds = timestamp - last_constrained_time;
    const auto coarse = static_cast<std::size_t>(config.preprocess.levels - 1);
    return std::min(config.relocalization_max_radius,
                    std::max<double>(config.icp.max_distance[coarse],
                                     0.5 * config.relocalization_drift_acceleration * lost_seconds * lost_seconds));
  }

  // A loss long enough that the dead-reckoned seed may lie beyond ICP's reach: an alignment
  // from it can settle on the wrong stretch of a weakly constrained view, so recovery must be
  // confirmed by the relocalization search.
  bool long_loss(double timestamp, const MotionPrediction& prediction) const {
    const auto coarse = static_cast<std::size_t>(config.preprocess.levels - 1);
    return config.relocalize_with_imu && prediction.rotation_from_imu && machine.status() == TrackingStatus::kLost &&
           drift_radius(timestamp) > config.icp.max_distance[coarse];
  }

  // Whether this frame searches for its pose (see ReconstructorConfig::relocalize_with_imu):
  // every relocalization_interval lost frames, and whenever ICP from the seed would end a long
  // loss.
  bool may_relocalize(const IcpResult& icp, const MotionPrediction& prediction, bool long_loss) {
    if (machine.status() != TrackingStatus::kLost) {
      lost_frames_since_attempt = 0;
      return false;
    }
    if (!config.relocalize_with_imu || !prediction.rotation_from_imu) return false;
    if (icp.reliable) return long_loss;
    if (++lost_frames_since_attempt < config.relocalization_interval) return false;
    lost_frames_since_attempt = 0;
    return true;
  }

  Status build_field() {
    auto snapshot = volume.snapshot();
    if (!snapshot) return snapshot.error();
    std::vector<Eigen::Vector3d> surface = volume_surface_points(*snapshot);
    // Only the region a search can reach: an unbounded scene costs no more than a room.
    const double cutoff = 4 * config.relocalization_cell;
    const Eigen::Vector3d anchor = trajectory[last_constrained_index].T_world_camera.translation();
    const double reach = config.relocalization_max_radius + config.preprocess.max_depth + cutoff;
    std::erase_if(surface, [&](const Eigen::Vector3d& p) { return (p - anchor).cwiseAbs().maxCoeff() > reach; });
    field = SurfaceDistanceField(surface, config.relocalization_cell, cutoff);
    field_current = true;
    return {};
  }

  // The translation search and ICP from its best candidates; the reliable, converged alignment
  // with the lowest residual per weight, if it is the only place the frame fits: when another
  // candidate's ICP also passes every test but the condition number somewhere else (more than
  // two cells away), the view is ambiguous (a wall and the floor slide along their common line)
  // and nothing is accepted.
  Result<std::optional<Relocalization>> relocalize(const DepthImage& depth, const Eigen::Isometry3d& T_world_estimate,
                                                   double timestamp, FrameTimings& timings) {
    const auto t0 = Clock::now();
    const double icp_ms = timings.icp_ms, raycast_ms = timings.raycast_ms;
    if (!field_current) IMUFUSION_RETURN_IF_ERROR(build_field());
    const int coarse = config.preprocess.levels - 1;
    const double radius = drift_radius(timestamp);
    const Intrinsics& k = current.intrinsics(coarse);
    auto map = download_map(current.vertices(coarse), k.width, k.height);
    if (!map) return map.error();
    std::vector<Eigen::Vector3d> points;
    for (const Eigen::Vector4f& v : map->data)
      if (v.w() > 0.5f) points.push_back(v.head<3>().cast<double>());
    constexpr std::size_t kMaxPoints = 800;  // enough for a chamfer fit; the search is linear in it
    if (points.size() > kMaxPoints) {
      std::vector<Eigen::Vector3d> kept;
      const double stride = static_cast<double>(points.size()) / kMaxPoints;
      for (std::size_t i = 0; i < kMaxPoints; ++i) kept.push_back(points[static_cast<std::size_t>(static_cast<double>(i) * stride)]);
      points = std::move(kept);
    }
    std::vector<TranslationCandidate> candidates = field.search(
        points, T_world_estimate.linear(), T_world_estimate.translation(), radius, config.relocalization_candidates);
    if (radius >= config.relocalization_max_radius) {
      // Dead reckoning may have drifted beyond the search by now, while a hand-held camera that
      // turns back to the scanned model is seldom far from where the scan was lost: search
      // there too.
      const Eigen::Vector3d lost_at = trajectory[last_constrained_index].T_world_camera.translation();
      candidates = merge_candidates(candidates,
                                    field.search(points, T_world_estimate.linear(), lost_at,
                                                 config.relocalization_max_radius, config.relocalization_candidates),
                                    config.relocalization_candidates, 2 * config.relocalization_cell);
    }
    std::optional<Relocalization> best;
    IcpReliabilityThresholds plausible = reliability(depth);
    plausible.max_condition = std::numeric_limits<double>::infinity();
    std::vector<Eigen::Vector3d> fits;  // where the frame fits but for the condition number
    for (const TranslationCandidate& c : candidates) {
      if (c.near_fraction < plausible.min_inlier_fraction) continue;
      Eigen::Isometry3d T_candidate = T_world_estimate;
      T_candidate.translation() = c.translation;
      IMUFUSION_RETURN_IF_ERROR(update_reference(T_candidate, timings));
      // No IMU prediction: the full six-direction solve, which a wall alone cannot pass.
      auto icp = align(depth, T_candidate, MotionPrediction{}, true, timings);
      if (!icp) return icp.error();
      const Eigen::Isometry3d T_world_camera = T_world_reference * icp->T_ref_cur;
      if (icp->quality.iterations > 0 && judge_icp(icp->quality, plausible, nullptr))
        fits.push_back(T_world_camera.translation());
      if (!icp->reliable || !icp->quality.converged) continue;
      if (!best || icp->quality.residual_per_weight < best->icp.quality.residual_per_weight)
        best = Relocalization{*icp, T_world_camera};
    }
    const double apart = 2 * config.relocalization_cell;
    if (best && std::any_of(fits.begin(), fits.end(), [&](const Eigen::Vector3d& p) {
          return (p - best->T_world_camera.translation()).norm() > apart;
        }))
      best.reset();
    timings.icp_ms = icp_ms;
    timings.raycast_ms = raycast_ms;
    timings.relocalize_ms = ms_since(t0);
    return best;
  }

  // The lost frames kept, placed by ICP backward from the recovery: frame i's seed is frame
  // i+1's placed pose moved by dead reckoning's motion between the two (accurate over a frame
  // however far dead reckoning has drifted), full six-direction ICP as while lost, until a frame
  // is not reliably placed or was not kept. The correction that remains is then measured at the
  // oldest frame placed, and only the frames before it are re-estimated by the drift model.
  // Returns that correction and the frames placed (index and pose). Leaves the current frame
  // and, when `moved_reference`, the reference to the caller to restore.
  struct Retracked {
    PendingCorrection correction;
    std::vector<std::pair<std::size_t, Eigen::Isometry3d>> placed;
    bool moved_reference = false;
  };
  Result<Retracked> retrack(const PendingCorrection& c) {
    // Everything but the kept depth, which only this pass reads.
    Retracked out{{c.anchor, c.index, c.estimate, c.corrected, c.prior, c.fixed, {}}, {}, false};
    PendingCorrection& at = out.correction;
    FrameTimings scratch;
    for (auto it = c.depth.rbegin(); it != c.depth.rend(); ++it) {
      const std::size_t i = it->first;
      if (i >= at.index) continue;  // the recovering frames' own, kept for restart_pending()
      if (i + 1 != at.index || i <= c.anchor) break;
      const Eigen::Isometry3d& dead = trajectory[i].T_world_camera;
      const Eigen::Isometry3d seed = at.corrected * at.estimate.inverse() * dead;
      // Where dead reckoning put frame i before partial ICP moved it, if it did: the frames
      // before reach it by dead reckoning alone, so the correction left there is measured from it.
      Eigen::Isometry3d dead_reckoned = dead;
      if (const PartialFrame* partial = find_partial(c.fixed, i)) dead_reckoned.translation() -= partial->moved;
      IMUFUSION_RETURN_IF_ERROR(preprocess(it->second, nullptr, scratch));
      out.moved_reference = true;
      IMUFUSION_RETURN_IF_ERROR(update_reference(seed, scratch));
      auto icp = align(it->second, seed, MotionPrediction{}, true, scratch);
      if (!icp) return icp.error();
      if (!icp->reliable || !icp->quality.converged) break;
      at.index = i;
      at.estimate = dead_reckoned;
      at.corrected = T_world_reference * icp->T_ref_cur;
      out.placed.emplace_back(i, at.corrected);
    }
    return out;
  }

  void keep_depth(std::deque<std::pair<std::size_t, DepthImage>>& kept, std::size_t index,
                  const DepthImage& depth) const {
    kept.emplace_back(index, depth);
    if (kept.size() > static_cast<std::size_t>(config.retrack_lost_frames)) kept.pop_front();
  }

  // ReconstructorConfig::recovery_agreement_distance: whether this recovering frame's ICP settled
  // too far from its seed to agree with the frames counted before it.
  bool disagrees_with_recovery(const IcpResult& icp, const FrameResult& r,
                               const Eigen::Isometry3d& T_world_seed,
                               const Eigen::Isometry3d& T_world_icp) const {
    const double limit = config.recovery_agreement_distance;
    return limit > 0 && machine.status() == TrackingStatus::kRecovering && pending.has_value() &&
           r.imu.translation_predicted && icp.reliable && icp.quality.converged &&
           (T_world_icp.translation() - T_world_seed.translation()).norm() > limit;
  }

  // Frame `index` restarted the recovery: the recovering frames before it (pending->index up to
  // index - 1) fit the model at the wrong place. They go back to where dead reckoning would have
  // put them (their ICP chain moved by the first one's correction, undone), and the stretch now
  // ends at this frame, seeded at `T_world_seed`, placed at `T_world_icp`.
  void restart_pending(std::size_t index, const Eigen::Isometry3d& T_world_seed,
                       const Eigen::Isometry3d& T_world_icp) {
    if (!pending) return;
    const Eigen::Isometry3d undo = pending->estimate * pending->corrected.inverse();
    for (std::size_t i = pending->index; i < index; ++i)
      trajectory[i].T_world_camera = undo * trajectory[i].T_world_camera;
    pending->index = index;
    pending->estimate = undo * T_world_seed;
    pending->corrected = T_world_icp;
  }

  // The lost stretch `c` ends at frames ICP placed (a recovery, or a broken one's frames): its
  // kept frames are placed backward, the rest re-estimated (see Reconstructor::trajectory()).
  // `r` is the current frame, already in the trajectory: the reference goes back to its pose.
  Status settle_lost_stretch(const PendingCorrection& c, FrameResult& r) {
    const auto t1 = Clock::now();
    auto retracked = retrack(c);
    if (!retracked) return retracked.error();
    if (retracked->moved_reference) IMUFUSION_RETURN_IF_ERROR(update_reference(r.T_world_camera, r.timings));
    if (config.retracked_frame_sigma > 0)
      correct_lost_stretch(c, retracked->placed);
    else
      correct_lost_stretch(retracked->correction, {});
    for (const auto& [index, pose] : retracked->placed) trajectory[index].T_world_camera = pose;
    r.retracked = retracked->placed.size();
    r.timings.retrack_ms = ms_since(t1);
    return {};
  }

  // See Reconstructor::trajectory().
  // `placed`: the frames the retrack placed (c.index - 1 and down, newest first), each measuring
  // the error there with ReconstructorConfig::retracked_frame_sigma; they keep their placed
  // poses. Empty: `c` ends at the oldest frame placed.
  void correct_lost_stretch(const PendingCorrection& c,
                            const std::vector<std::pair<std::size_t, Eigen::Isometry3d>>& placed) {
    const std::size_t first_placed = c.index - placed.size();
    const double span = trajectory[c.index].timestamp - trajectory[c.anchor].timestamp;
    if (!(span > 0)) return;
    const StretchCorrection end = end_error(c);
    const std::vector<StretchCorrection> corrections =
        drift_corrections(stretch_frames(c, placed), span, end.translation, end.rotation, c.prior);
    for (std::size_t i = c.anchor + 1; i < first_placed; ++i) {
      const StretchCorrection& correction = corrections[i - c.anchor - 1];
      Eigen::Isometry3d& T = trajectory[i].T_world_camera;
      T.linear() = inertial::exp_so3(correction.rotation) * T.linear();
      T.translation() += correction.translation;
    }
  }

  // The velocity error (world) dead reckoning carried to the end of the stretch `c`, which ends
  // at `end_time` (the current frame, not yet in the trajectory), under the drift model; none
  // where the end error is not a drift the model explains (drift_end_velocity).
  std::optional<Eigen::Vector3d> stretch_end_velocity_error(const PendingCorrection& c, double end_time) const {
    const StretchCorrection end = end_error(c);
    return drift_end_velocity(stretch_frames(c, {}), end_time - trajectory[c.anchor].timestamp, end.translation,
                              end.rotation, c.prior);
  }

  // The error the stretch's end shows: truth (where ICP placed it) - estimate (dead reckoning).
  static StretchCorrection end_error(const PendingCorrection& c) {
    return {c.corrected.translation() - c.estimate.translation(),
            inertial::log_so3(c.corrected.linear() * c.estimate.linear().transpose())};
  }

  // The frames strictly inside the stretch `c`, for drift_corrections (see correct_lost_stretch).
  std::vector<StretchFrame> stretch_frames(const PendingCorrection& c,
                                           const std::vector<std::pair<std::size_t, Eigen::Isometry3d>>& placed) const {
    const std::size_t first_placed = c.index - placed.size();
    const double t0 = trajectory[c.anchor].timestamp;
    std::vector<StretchFrame> frames;
    for (std::size_t i = c.anchor + 1; i < c.index; ++i) {
      StretchFrame f;
      f.s = trajectory[i].timestamp - t0;
      f.R_world_camera = trajectory[i].T_world_camera.linear();
      if (const PartialFrame* fixed = find_partial(c.fixed, i)) {
        f.fixed = fixed->fixed;
        if (fixed->measured) {
          f.moved = fixed->moved;
          f.moved_sigma = config.partial_move_sigma;
        }
      }
      if (i >= first_placed) {
        f.observed = placed[c.index - 1 - i].second.translation() - trajectory[i].T_world_camera.translation();
        f.observed_sigma = config.retracked_frame_sigma;
      }
      frames.push_back(f);
    }
    return frames;
  }

  InertialStatus inertial_status() const { return navigator ? navigator->status() : InertialStatus{}; }

  DriftPrior drift_prior() const {
    DriftPrior prior;
    if (!navigator) return prior;
    const InertialStatus s = navigator->status();
    if (s.gravity_ready) prior.gravity_world = s.gravity_world;
    prior.velocity_sigma = s.velocity_sigma;
    // The reported sigmas (per-axis RMS) scaled by their measured calibration. Gravity and the
    // accelerometer bias as independent: their estimator's joint covariance (the two are
    // strongly correlated while the camera turned little) did worse on twelve wall scans
    // (bench/README.md).
    if (s.gravity_ready) {
      const double scale2 = config.drift_gravity_sigma_scale * config.drift_gravity_sigma_scale;
      prior.gravity_bias_covariance.topLeftCorner<3, 3>().diagonal().setConstant(scale2 * s.gravity_sigma.squaredNorm() / 3);
      prior.gravity_bias_covariance.bottomRightCorner<3, 3>().diagonal().setConstant(scale2 * s.accel_bias_sigma.squaredNorm() / 3);
    }
    prior.gyro_bias_sigma = config.drift_gyro_bias_sigma_scale * s.gyro_bias_sigma.norm() / std::sqrt(3.0);
    prior.gyro_noise_density = config.inertial.gyro_noise_density;
    return prior;
  }
};

Reconstructor::Reconstructor(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;

Result<Reconstructor> Reconstructor::create(const ReconstructorConfig& config) {
  IMUFUSION_RETURN_IF_ERROR(config.validate());
  auto context = gpu::Context::create(config.device);
  if (!context) return context.error();
  auto impl = std::make_unique<Impl>();
  Impl& m = *impl;
  m.config = config;
  m.context = *context;
  m.machine = TrackingStateMachine(config.tracking);
  m.pairing = PairingReference(config.tracking);
  const Intrinsics& k = config.intrinsics;
  const auto pixels = static_cast<std::size_t>(k.width) * k.height;
  for (gpu::Preprocessor* p : {&m.current, &m.reference}) {
    auto created = gpu::Preprocessor::create(m.context, config.preprocess, k);
    if (!created) return created.error();
    *p = std::move(*created);
  }
  auto pre_seq = gpu::CommandSequence::create(m.context, m.current.dispatch_count());
  if (!pre_seq) return pre_seq.error();
  m.preprocess_seq = std::move(*pre_seq);
  auto icp_seq = gpu::CommandSequence::create(m.context, gpu::IcpKernels::kDispatches);
  if (!icp_seq) return icp_seq.error();
  m.icp_seq = std::move(*icp_seq);
  auto kernels = gpu::IcpKernels::create(m.context, pixels, config.preprocess.workgroup_x,
                                         config.preprocess.workgroup_y, config.icp.depth_noise,
                                         config.icp.normal_gate);
  if (!kernels) return kernels.error();
  m.icp_kernels = std::move(*kernels);
  auto volume = gpu::TsdfVolume::create(m.context, config.volume, config.preprocess.workgroup_x,
                                        config.preprocess.workgroup_y);
  if (!volume) return volume.error();
  m.volume = std::move(*volume);
  auto color = gpu::Buffer::create(m.context, pixels * 4);
  if (!color) return color.error();
  m.color = std::move(*color);
  auto model = RaycastBuffers::create(m.context, pixels);
  if (!model) return model.error();
  m.model = std::move(*model);
  if (config.use_imu) {
    auto navigator = InertialNavigator::create(config.inertial);
    if (!navigator) return navigator.error();
    m.navigator.emplace(std::move(*navigator));
  }
  return Reconstructor(std::move(impl));
}

Result<FrameResult> Reconstructor::track_and_fuse(double timestamp, const DepthImage& depth,
                                                  const ColorImage* color,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));

  TrackingDecision decision;
  if (!m.machine.started() || !m.has_reference) {
    // The scan starts at its first frame with depth enough to track against; before it, the
    // frame waits at the initial pose, lost, and the machine stays unstarted.
    if (m.valid_depth_pixels(depth) >= m.config.icp.reliability.min_inliers)
      decision = m.machine.start();
    else
      decision = {TrackingStatus::kLost, PoseSource::kInitial, false, 0, false};
    r.T_world_camera = m.config.initial_pose;
  } else {
    const StampedPose& previous = m.trajectory.back();
    if (m.navigator) r.imu = m.navigator->predict(previous.timestamp, timestamp);
    const Eigen::Isometry3d T_world_seed = previous.T_world_camera * r.imu.T_a_b;
    auto icp = m.align(depth, T_world_seed, r.imu, m.machine.recovering_or_lost(), r.timings);
    if (!icp) return icp.error();
    const Eigen::Matrix3d R_world_reference = m.T_world_reference.linear();
    Eigen::Isometry3d T_world_icp = m.T_world_reference * icp->T_ref_cur;
    // Where the frame would be without a recovery: the partial pose, else dead reckoning.
    const Eigen::Isometry3d T_world_estimate = icp->partial ? T_world_icp : T_world_seed;
    const bool long_loss = m.long_loss(timestamp, r.imu);
    if (m.may_relocalize(*icp, r.imu, long_loss)) {
      auto found = m.relocalize(depth, T_world_estimate, timestamp, r.timings);
      if (!found) return found.error();
      if (*found) {
        icp = (*found)->icp;
        T_world_icp = (*found)->T_world_camera;
        r.relocalized = true;
      }
    }
    if (long_loss && icp->reliable && !r.relocalized) {
      icp->reliable = false;
      icp->reason = "after a long loss, not confirmed as the only fit by the relocalization search";
    }
    const bool was_lost = m.machine.status() == TrackingStatus::kLost;
    const bool partial_may_fuse = timestamp - m.last_constrained_time <= m.config.max_partial_seconds;
    if (icp->partial && !partial_may_fuse && !m.machine.recovering_or_lost()) {
      char limit[32];
      std::snprintf(limit, sizeof limit, "%.3g", m.config.max_partial_seconds);
      icp->reason += std::string("; partial for more than ") + limit + " s";
    }
    r.icp_ran = true;
    r.icp = *icp;
    r.recovery_restarted = m.disagrees_with_recovery(*icp, r, T_world_seed, T_world_icp);
    if (r.recovery_restarted) m.machine.restart_recovery();
    decision = m.machine.step(icp->reliable, icp->quality.converged, icp->partial, partial_may_fuse);
    if (decision.status == TrackingStatus::kTracking && decision.source == PoseSource::kIcp)
      m.pairing.add(icp->quality.inlier_fraction, icp->quality.pixel_fraction);
    m.seed_gate_holding = decision.status == TrackingStatus::kTracking && icp->quality.seed_gated_directions > 0;
    const bool icp_pose = decision.source == PoseSource::kIcp || decision.source == PoseSource::kIcpPartial;
    r.T_world_camera = icp_pose ? T_world_icp : T_world_seed;
    // A pair measures the motion only when both poses came from ICP against the same model:
    // the first frame placed after a loss (relocalized or not) also undoes dead reckoning's
    // drift, and a restarted recovery's frame undoes a wrong fit.
    if (m.navigator) {
      m.navigator->observe(previous.timestamp, timestamp, previous.T_world_camera, r.T_world_camera,
                           decision.source == PoseSource::kIcp && !was_lost && !r.recovery_restarted);
      if (r.recovery_restarted) m.navigator->forget_velocity();
    }
    if (r.recovery_restarted) m.restart_pending(r.index, T_world_seed, r.T_world_camera);
    if (was_lost && decision.status == TrackingStatus::kRecovering) {
      // The correction is measured from where dead reckoning put the frame (a partial pose's
      // rotation kept, as in the stretch): the frames before reach it by dead reckoning alone.
      Eigen::Isometry3d T_world_dead = T_world_estimate;
      T_world_dead.translation() = T_world_seed.translation();
      m.pending = Impl::PendingCorrection{m.last_constrained_index, r.index, T_world_dead, r.T_world_camera,
                                          m.constrained_prior, m.partial_fixed, std::move(m.lost_depth)};
      // The velocity dead reckoning carried out of the loss, corrected by the drift it shows.
      if (m.navigator && m.config.correct_velocity_after_loss) {
        if (const auto dv = m.stretch_end_velocity_error(*m.pending, timestamp)) m.navigator->correct_velocity(*dv);
      }
    }
    // Taken as exact only while dead reckoning is still within ICP's reach: from a seed further
    // off, partial ICP may settle on the wrong stretch of the model in the directions it fixes
    // too, so there its move is a measurement to be checked (ReconstructorConfig::partial_move_sigma).
    if (decision.source == PoseSource::kIcpPartial && (!long_loss || m.config.partial_move_sigma > 0))
      m.partial_fixed.push_back({r.index, R_world_reference * icp->fixed_translation * R_world_reference.transpose(),
                                 T_world_icp.translation() - T_world_seed.translation(), long_loss});
  }
  if (decision.source == PoseSource::kIcp || decision.source == PoseSource::kInitial) {
    m.last_constrained_time = timestamp;
    m.last_constrained_index = r.index;
    m.constrained_prior = m.drift_prior();
    m.partial_fixed.clear();
    m.lost_depth.clear();
  } else if (m.config.retrack_lost_frames > 0) {
    m.keep_depth(m.lost_depth, r.index, depth);
  }
  // A recovering frame rejoins the lost stretch if a later one disagrees with it (restart_pending).
  if (decision.status == TrackingStatus::kRecovering && m.pending && m.config.retrack_lost_frames > 0)
    m.keep_depth(m.pending->depth, r.index, depth);
  r.status = decision.status;
  r.source = decision.source;
  r.recovered = decision.recovered;
  if (decision.fuse) {
    auto stats = m.integrate(color != nullptr, r.T_world_camera, r.timings);
    if (!stats) return stats.error();
    r.integration = *stats;
    r.fused = true;
    m.field_current = false;
  }
  IMUFUSION_RETURN_IF_ERROR(m.update_reference(r.T_world_camera, r.timings));
  if (decision.source == PoseSource::kInitial && decision.fuse) IMUFUSION_RETURN_IF_ERROR(m.pair_with_own_model(r.timings));
  m.trajectory.push_back({timestamp, r.T_world_camera});
  // The stretch ends at a recovery, or at a broken one: its recovering frames keep the poses ICP
  // placed them at, and the frames lost after them are dead-reckoned from there, so the stretch
  // before is re-estimated to meet them now.
  if ((decision.recovered || decision.status == TrackingStatus::kLost) && m.pending) {
    IMUFUSION_RETURN_IF_ERROR(m.settle_lost_stretch(*m.pending, r));
    m.pending.reset();
  }
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

Result<FrameResult> Reconstructor::fuse_with_pose(double timestamp, const DepthImage& depth,
                                                  const ColorImage* color,
                                                  const Eigen::Isometry3d& T_world_camera,
                                                  std::span<const ImuSample> imu) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  IMUFUSION_RETURN_IF_ERROR(m.check_frame(timestamp, depth, color));
  if (!T_world_camera.matrix().allFinite())
    return make_error(ErrorCode::kInvalidArgument, "known pose at t=" + std::to_string(timestamp) + " is not finite");
  IMUFUSION_RETURN_IF_ERROR(m.add_imu(imu));
  FrameResult r;
  r.index = m.trajectory.size();
  r.timestamp = timestamp;
  r.T_world_camera = T_world_camera;
  r.status = TrackingStatus::kTracking;
  r.source = PoseSource::kKnown;
  m.last_constrained_time = timestamp;
  m.last_constrained_index = r.index;
  m.constrained_prior = m.drift_prior();
  m.pending.reset();
  m.partial_fixed.clear();
  m.lost_depth.clear();
  if (!m.trajectory.empty() && m.navigator) {
    const StampedPose& previous = m.trajectory.back();
    r.imu = m.navigator->predict(previous.timestamp, timestamp);
    m.navigator->observe(previous.timestamp, timestamp, previous.T_world_camera, T_world_camera, true);
  }
  if (!m.machine.started()) m.machine.start();
  IMUFUSION_RETURN_IF_ERROR(m.preprocess(depth, color, r.timings));
  auto stats = m.integrate(color != nullptr, T_world_camera, r.timings);
  if (!stats) return stats.error();
  r.integration = *stats;
  r.fused = true;
  m.field_current = false;
  m.trajectory.push_back({timestamp, T_world_camera});
  r.inertial = m.inertial_status();
  r.timings.total_ms = ms_since(t0);
  return r;
}

Result<std::size_t> Reconstructor::finish() {
  Impl& m = *impl_;
  // A pending correction exists from a loss's first recovering frame until the recovery
  // completes or breaks: here, the scan ends while recovering.
  if (!m.pending || m.trajectory.empty()) return std::size_t{0};
  FrameResult last;
  last.T_world_camera = m.trajectory.back().T_world_camera;
  IMUFUSION_RETURN_IF_ERROR(m.settle_lost_stretch(*m.pending, last));
  m.pending.reset();
  return last.retracked;
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
  if (k.width <= 0 || k.height <= 0) return make_error(ErrorCode::kInvalidArgument, "raycast of an empty image");
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
  IMUFUSION_RETURN_IF_ERROR(m.volume.reset());
  m.machine.reset();
  m.pairing.reset();
  if (m.navigator) m.navigator->reset();
  m.trajectory.clear();
  m.has_reference = false;
  m.seed_gate_holding = false;
  m.field_current = false;
  m.pending.reset();
  m.partial_fixed.clear();
  m.lost_depth.clear();
  m.last_constrained_time = 0;
  m.last_constrained_index = 0;
  m.lost_frames_since_attempt = 0;
  m.T_world_reference = Eigen::Isometry3d::Identity();
  return {};
}

const Trajectory& Reconstructor::trajectory() const { return impl_->trajectory; }
const ReconstructorConfig& Reconstructor::config() const { return impl_->config; }
const DeviceInfo& Reconstructor::device() const { return impl_->context->info(); }
std::uint32_t Reconstructor::allocated_blocks() const { return impl_->volume.allocated_blocks(); }
std::uint64_t Reconstructor::memory_bytes() const { return impl_->volume.config().reserved_bytes(); }
std::uint32_t Reconstructor::validation_error_count() const {
  return impl_->context->validation_error_count();
}

}  // namespace imufusion
