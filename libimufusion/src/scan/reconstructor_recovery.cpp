// Reconstructor::Impl, recovery from a loss: relocalization (a search of the model for where a lost
// frame fits) and the lost-stretch correction (the kept frames placed backward from the recovery,
// the rest re-estimated by the drift model).

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/inertial_internal.hpp"
#include "scan/reconstructor_impl.hpp"

namespace imufusion {

// How far dead reckoning may have drifted since the last fully constrained frame (m), from
// the coarsest ICP level's reach up to relocalization.max_radius.
double Reconstructor::Impl::drift_radius(double timestamp) const {
  const double lost_seconds = timestamp - last_constrained_time;
  const auto coarse = static_cast<std::size_t>(config.preprocess.levels - 1);
  return std::min(config.relocalization.max_radius,
                  std::max<double>(config.icp.max_distance[coarse],
                                   0.5 * config.relocalization.drift_acceleration * lost_seconds *
                                       lost_seconds));
}

// A loss long enough that the dead-reckoned seed may lie beyond ICP's reach: an alignment
// from it can settle on the wrong stretch of a weakly constrained view, so recovery must be
// confirmed by the relocalization search.
bool Reconstructor::Impl::long_loss(double timestamp, const MotionPrediction& prediction) const {
  const auto coarse = static_cast<std::size_t>(config.preprocess.levels - 1);
  return config.relocalization.enabled && prediction.rotation_from_imu &&
         machine.status() == TrackingStatus::kLost &&
         drift_radius(timestamp) > config.icp.max_distance[coarse];
}

// Whether this frame searches for its pose (see ReconstructorConfig::relocalization.enabled):
// every relocalization.interval lost frames, and whenever ICP from the seed would end a long
// loss.
bool Reconstructor::Impl::may_relocalize(const IcpResult& icp, const MotionPrediction& prediction,
                                         bool long_loss) {
  if (machine.status() != TrackingStatus::kLost) {
    lost_frames_since_attempt = 0;
    return false;
  }
  if (!config.relocalization.enabled || !prediction.rotation_from_imu) return false;
  if (icp.reliable()) return long_loss;
  if (++lost_frames_since_attempt < config.relocalization.interval) return false;
  lost_frames_since_attempt = 0;
  return true;
}

Status Reconstructor::Impl::build_field() {
  auto snapshot = volume.snapshot();
  if (!snapshot) return snapshot.error();
  std::vector<Eigen::Vector3d> surface = volume_surface_points(*snapshot);
  // Only the region a search can reach: an unbounded scene costs no more than a room.
  const double cutoff = 4 * config.relocalization.cell;
  const Eigen::Vector3d anchor = trajectory[last_constrained_index].T_world_camera.translation();
  const double reach = config.relocalization.max_radius + config.preprocess.max_depth + cutoff;
  std::erase_if(surface, [&](const Eigen::Vector3d& p) {
    return (p - anchor).cwiseAbs().maxCoeff() > reach;
  });
  field = SurfaceDistanceField(surface, config.relocalization.cell, cutoff);
  field_current = true;
  return {};
}

// The translation search and ICP from its best candidates; the reliable, converged alignment
// with the lowest residual per weight, if it is the only place the frame fits: when another
// candidate's ICP also passes every test but the condition number somewhere else (more than
// two cells away), the view is ambiguous (a wall and the floor slide along their common line)
// and nothing is accepted.
Result<std::optional<Reconstructor::Impl::Relocalization>> Reconstructor::Impl::relocalize(
    const DepthImage& depth, const Eigen::Isometry3d& T_world_estimate, double timestamp,
    FrameTimings& timings) {
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
    for (std::size_t i = 0; i < kMaxPoints; ++i)
      kept.push_back(points[static_cast<std::size_t>(static_cast<double>(i) * stride)]);
    points = std::move(kept);
  }
  std::vector<TranslationCandidate> candidates =
      field.search(points, T_world_estimate.linear(), T_world_estimate.translation(), radius,
                   config.relocalization.candidates);
  // Dead reckoning may have drifted beyond the search, while a hand-held camera that turns back
  // to the scanned model is seldom far from where the scan was lost: search there too.
  const Eigen::Vector3d lost_at = trajectory[last_constrained_index].T_world_camera.translation();
  if ((lost_at - T_world_estimate.translation()).norm() > config.relocalization.cell) {
    candidates = merge_candidates(candidates,
                                  field.search(points, T_world_estimate.linear(), lost_at, radius,
                                               config.relocalization.candidates),
                                  config.relocalization.candidates, 2 * config.relocalization.cell);
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
    if (!icp->reliable() || !icp->quality.converged) continue;
    if (!best || icp->quality.residual_per_weight < best->icp.quality.residual_per_weight)
      best = Relocalization{*icp, T_world_camera};
  }
  const double apart = 2 * config.relocalization.cell;
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
Result<Reconstructor::Impl::Retracked> Reconstructor::Impl::retrack(const PendingCorrection& c) {
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
    if (const PartialFrame* partial = find_partial(c.fixed, i))
      dead_reckoned.translation() -= partial->moved;
    IMUFUSION_RETURN_IF_ERROR(preprocess(it->second, nullptr, scratch));
    out.moved_reference = true;
    IMUFUSION_RETURN_IF_ERROR(update_reference(seed, scratch));
    auto icp = align(it->second, seed, MotionPrediction{}, true, scratch);
    if (!icp) return icp.error();
    if (!icp->reliable() || !icp->quality.converged) break;
    at.index = i;
    at.estimate = dead_reckoned;
    at.corrected = T_world_reference * icp->T_ref_cur;
    out.placed.emplace_back(i, at.corrected);
  }
  return out;
}

void Reconstructor::Impl::keep_depth(std::deque<std::pair<std::size_t, DepthImage>>& kept,
                                     std::size_t index, const DepthImage& depth) const {
  kept.emplace_back(index, depth);
  if (kept.size() > static_cast<std::size_t>(config.smoothing.retrack_frames)) kept.pop_front();
}

// ReconstructorConfig::recovery.agreement_distance: whether this recovering frame's ICP settled
// too far from its seed to agree with the frames counted before it.
bool Reconstructor::Impl::disagrees_with_recovery(const IcpResult& icp, const FrameResult& r,
                                                  const Eigen::Isometry3d& T_world_seed,
                                                  const Eigen::Isometry3d& T_world_icp) const {
  const double limit = config.recovery.agreement_distance;
  return limit > 0 && machine.status() == TrackingStatus::kRecovering && pending.has_value() &&
         r.imu.translation_predicted && icp.reliable() && icp.quality.converged &&
         (T_world_icp.translation() - T_world_seed.translation()).norm() > limit;
}

// Frame `index` restarted the recovery: the recovering frames before it (pending->index up to
// index - 1) fit the model at the wrong place. They go back to where dead reckoning would have
// put them (their ICP chain moved by the first one's correction, undone), and the stretch now
// ends at this frame, seeded at `T_world_seed`, placed at `T_world_icp`.
void Reconstructor::Impl::restart_pending(std::size_t index, const Eigen::Isometry3d& T_world_seed,
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
Status Reconstructor::Impl::settle_lost_stretch(const PendingCorrection& c, FrameResult& r) {
  const auto t1 = Clock::now();
  auto retracked = retrack(c);
  if (!retracked) return retracked.error();
  if (retracked->moved_reference)
    IMUFUSION_RETURN_IF_ERROR(update_reference(r.T_world_camera, r.timings));
  if (config.smoothing.retracked_frame_sigma > 0)
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
// the error there with ReconstructorConfig::smoothing.retracked_frame_sigma; they keep their placed
// poses. Empty: `c` ends at the oldest frame placed.
void Reconstructor::Impl::correct_lost_stretch(
    const PendingCorrection& c,
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
    T.linear() = exp_so3(correction.rotation) * T.linear();
    T.translation() += correction.translation;
  }
}

// The velocity error (world) dead reckoning carried to the end of the stretch `c`, which ends
// at `end_time` (the current frame, not yet in the trajectory), under the drift model; none
// where the end error is not a drift the model explains (drift_end_velocity).
std::optional<Eigen::Vector3d> Reconstructor::Impl::stretch_end_velocity_error(
    const PendingCorrection& c, double end_time) const {
  const StretchCorrection end = end_error(c);
  return drift_end_velocity(stretch_frames(c, {}), end_time - trajectory[c.anchor].timestamp,
                            end.translation, end.rotation, c.prior);
}

// The error the stretch's end shows: truth (where ICP placed it) - estimate (dead reckoning).
StretchCorrection Reconstructor::Impl::end_error(const PendingCorrection& c) {
  return {c.corrected.translation() - c.estimate.translation(),
          log_so3(c.corrected.linear() * c.estimate.linear().transpose())};
}

// The frames strictly inside the stretch `c`, for drift_corrections (see correct_lost_stretch).
std::vector<StretchFrame> Reconstructor::Impl::stretch_frames(
    const PendingCorrection& c,
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
        f.moved_sigma = config.smoothing.partial_move_sigma;
      }
    }
    if (i >= first_placed) {
      f.observed =
          placed[c.index - 1 - i].second.translation() - trajectory[i].T_world_camera.translation();
      f.observed_sigma = config.smoothing.retracked_frame_sigma;
    }
    frames.push_back(f);
  }
  return frames;
}

DriftPrior Reconstructor::Impl::drift_prior() const {
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
    const double scale2 =
        config.smoothing.gravity_sigma_scale * config.smoothing.gravity_sigma_scale;
    prior.gravity_bias_covariance.topLeftCorner<3, 3>().diagonal().setConstant(
        scale2 * s.gravity_sigma.squaredNorm() / 3);
    prior.gravity_bias_covariance.bottomRightCorner<3, 3>().diagonal().setConstant(
        scale2 * s.accel_bias_sigma.squaredNorm() / 3);
  }
  prior.gyro_bias_sigma =
      config.smoothing.gyro_bias_sigma_scale * s.gyro_bias_sigma.norm() / std::sqrt(3.0);
  prior.gyro_noise_density = config.inertial.gyro_noise_density;
  return prior;
}

}  // namespace imufusion
