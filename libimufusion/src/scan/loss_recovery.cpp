// LossRecovery: the lost stretch's bookkeeping frame by frame, and its settling when it ends (the
// kept frames placed backward from the recovery, the rest re-estimated by the drift model).

#include "scan/loss_recovery.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/so3.hpp"
#include "core/state_fields.hpp"
#include "scan/clock.hpp"

namespace imufusion {

LossRecovery::LossRecovery(const ReconstructorConfig& config)
    : smoothing_(config.smoothing),
      recovery_(config.recovery),
      gyro_noise_density_(config.inertial.gyro_noise_density),
      max_translation_condition_(config.relocalization.max_translation_condition) {}

void LossRecovery::reset() {
  constrained_time_ = 0;
  constrained_index_ = 0;
  constrained_prior_ = {};
  partial_.clear();
  lost_depth_.clear();
  pending_.reset();
}

// Frame `index`'s entry in `frames` (sorted by index), or nullptr when partial ICP did not place
// it.
const LossRecovery::PartialFrame* LossRecovery::find_partial(
    const std::vector<PartialFrame>& frames, std::size_t index) {
  const auto it =
      std::lower_bound(frames.begin(), frames.end(), index,
                       [](const PartialFrame& f, std::size_t i) { return f.index < i; });
  return it != frames.end() && it->index == index ? &*it : nullptr;
}

bool LossRecovery::disagrees(TrackingStatus status, const IcpResult& icp,
                             const MotionPrediction& prediction,
                             const Eigen::Isometry3d& T_world_seed,
                             const Eigen::Isometry3d& T_world_icp) const {
  const double limit = recovery_.agreement_distance;
  return limit > 0 && status == TrackingStatus::kRecovering && pending_.has_value() &&
         prediction.translation_predicted && icp.reliable() && icp.quality.converged &&
         (T_world_icp.translation() - T_world_seed.translation()).norm() > limit;
}

Result<std::size_t> LossRecovery::on_frame(const Frame& frame, const DepthView& depth,
                                           InertialNavigator* navigator, Trajectory& trajectory,
                                           ModelAligner& model, FrameTimings& timings) {
  const TrackingDecision& decision = frame.decision;
  if (frame.restarted) restart_pending(frame, trajectory);
  // The first frame ICP placed after the loss. A relocalized one (tracking.
  // relocalized_recovery_frames 1), or any with recovery_frames 1, ends the loss itself (lost ->
  // tracking): its correction is settled at once below.
  if (frame.was_lost && (decision.status == TrackingStatus::kRecovering || decision.recovered))
    start_pending(frame, trajectory, navigator);
  // Taken as exact only while dead reckoning is still within ICP's reach: from a seed further
  // off, partial ICP may settle on the wrong stretch of the model in the directions it fixes
  // too, so there its move is a measurement to be checked (smoothing.partial_move_sigma).
  // Without the IMU the partial poses are the stretch's own estimate: the directions they hold
  // drift by the camera's whole motion, and a weakly constrained one may count as fixed, so the
  // recovery's correction spreads over every direction.
  // A frame that fixed more than a wall's three directions (its distance and two tilts, which
  // the wall measures) paired a few pixels off it while its position along the wall may still be
  // dead reckoning's: its turn may be wrong, and the recovery undoes it there.
  if (decision.source == PoseSource::kIcpPartial && navigator != nullptr &&
      (!frame.long_loss || smoothing_.partial_move_sigma > 0)) {
    const Eigen::Vector3d turned =
        frame.directions > kPlaneDirections
            ? log_so3(frame.T_world_camera.linear() * frame.T_world_seed.linear().transpose())
            : Eigen::Vector3d::Zero();
    partial_.push_back({frame.index, frame.fixed,
                        frame.T_world_camera.translation() - frame.T_world_seed.translation(),
                        turned, frame.long_loss});
  }
  update_stretch(frame, depth, navigator);
  // The stretch ends at a recovery, or at a broken one: its recovering frames keep the poses ICP
  // placed them at, and the frames lost after them are dead-reckoned from there, so the stretch
  // before is re-estimated to meet them now.
  if (decision.recovered || decision.status == TrackingStatus::kLost)
    return settle(trajectory, model, timings);
  return std::size_t{0};
}

// The one place the last fully constrained frame moves: the stretch starts again at it.
void LossRecovery::constrain(std::size_t index, double timestamp,
                             const InertialNavigator* navigator) {
  constrained_time_ = timestamp;
  constrained_index_ = index;
  constrained_prior_ = drift_prior(navigator);
  partial_.clear();
  lost_depth_.clear();
}

void LossRecovery::on_known_pose(std::size_t index, double timestamp,
                                 const InertialNavigator* navigator) {
  constrain(index, timestamp, navigator);
  pending_.reset();
}

LossRecovery::DepthCopy LossRecovery::DepthCopy::of(const DepthView& depth) {
  DepthCopy copy{depth, {}};
  const std::size_t row = depth.pixel_bytes() * static_cast<std::size_t>(depth.width);
  copy.bytes.resize(row * static_cast<std::size_t>(depth.height));
  for (int v = 0; v < depth.height; ++v)
    std::memcpy(copy.bytes.data() + row * static_cast<std::size_t>(v), depth.row(v), row);
  return copy;
}

DepthView LossRecovery::DepthCopy::view() const {
  DepthView d = layout;
  d.data = bytes.data();
  d.stride_bytes = 0;
  d.buffer_bytes = bytes.size();
  return d;
}

void LossRecovery::keep_depth(KeptDepth& kept, std::size_t index, const DepthView& depth) const {
  kept.emplace_back(index, DepthCopy::of(depth));
  if (kept.size() > static_cast<std::size_t>(smoothing_.retrack_frames)) kept.pop_front();
}

// The frame restarted the recovery: the recovering frames before it (pending index up to the
// frame's - 1) fit the model at the wrong place. They go back to where dead reckoning would have
// put them (their ICP chain moved by the first one's correction, undone), and the stretch now
// ends at this frame, seeded at its seed, placed at its pose.
void LossRecovery::restart_pending(const Frame& frame, Trajectory& trajectory) {
  if (!pending_) return;
  StretchEnd& end = pending_->end;
  const Eigen::Isometry3d undo = end.estimate * end.corrected.inverse();
  for (std::size_t i = end.index; i < frame.index; ++i)
    trajectory[i].T_world_camera = undo * trajectory[i].T_world_camera;
  end.index = frame.index;
  end.estimate = undo * frame.T_world_seed;
  end.corrected = frame.T_world_camera;
}

// A loss's first recovering frame: the stretch back to the last fully constrained frame is
// corrected by the difference between its pose and where dead reckoning put it, once the
// recovery completes or breaks.
void LossRecovery::start_pending(const Frame& frame, const Trajectory& trajectory,
                                 InertialNavigator* navigator) {
  // The correction is measured from where dead reckoning put the frame, its seed: the frames
  // before reach it by dead reckoning and their own partial moves and turns. Without the IMU
  // their turns are not recorded (the partial poses are the stretch's own estimate): a partial
  // pose's rotation is kept.
  Eigen::Isometry3d T_world_dead = frame.T_world_seed;
  if (navigator == nullptr) T_world_dead.linear() = frame.T_world_estimate.linear();
  pending_ = PendingCorrection{{constrained_index_, frame.index, T_world_dead, frame.T_world_camera,
                                constrained_prior_, partial_},
                               std::move(lost_depth_),
                               navigator != nullptr};
  // The velocity dead reckoning carried out of the loss, corrected by the drift it shows.
  if (navigator && recovery_.correct_velocity) {
    if (const auto dv = end_velocity_error(pending_->end, frame.timestamp, trajectory))
      navigator->correct_velocity(*dv);
  }
}

// The stretch since the last fully constrained frame: it starts again at this frame, or keeps
// its depth for a recovery to place backward.
void LossRecovery::update_stretch(const Frame& frame, const DepthView& depth,
                                  const InertialNavigator* navigator) {
  const PoseSource source = frame.decision.source;
  if (source == PoseSource::kIcp || source == PoseSource::kInitial)
    constrain(frame.index, frame.timestamp, navigator);
  else if (smoothing_.retrack_frames > 0)
    keep_depth(lost_depth_, frame.index, depth);
  // A recovering frame rejoins the lost stretch if a later one disagrees with it
  // (restart_pending).
  if (frame.decision.status == TrackingStatus::kRecovering && pending_ &&
      smoothing_.retrack_frames > 0)
    keep_depth(pending_->depth, frame.index, depth);
}

Result<std::size_t> LossRecovery::settle(Trajectory& trajectory, ModelAligner& model,
                                         FrameTimings& timings) {
  if (!pending_ || trajectory.empty()) return std::size_t{0};
  const auto t0 = Clock::now();
  const PendingCorrection& c = *pending_;
  auto retracked = retrack(c, trajectory, model);
  if (!retracked) return retracked.error();
  if (retracked->moved_reference)
    IMUFUSION_RETURN_IF_ERROR(model.set_reference(trajectory.back().T_world_camera, timings));
  if (smoothing_.retracked_frame_sigma > 0)
    correct_stretch(c.end, retracked->placed, trajectory);
  else
    correct_stretch(retracked->end, {}, trajectory);
  for (const auto& [index, pose] : retracked->placed) trajectory[index].T_world_camera = pose;
  timings.retrack_ms = ms_since(t0);
  pending_.reset();
  return retracked->placed.size();
}

// The lost frames kept, placed by ICP backward from the recovery: frame i's seed is frame
// i+1's placed pose moved by dead reckoning's motion between the two (accurate over a frame
// however far dead reckoning has drifted), full six-direction ICP as while lost, until a frame
// is not reliably placed, was not kept, or (without the IMU) settles farther than
// recovery.agreement_distance from its seed. The correction that remains is then measured at the
// oldest frame placed, and only the frames before it are re-estimated by the drift model.
// Returns that stretch end and the frames placed (index and pose, newest first). Leaves the
// current frame and, when `moved_reference`, the reference to the caller to restore.
Result<LossRecovery::Retracked> LossRecovery::retrack(const PendingCorrection& c,
                                                      const Trajectory& trajectory,
                                                      ModelAligner& model) const {
  Retracked out{c.end, {}, false};
  StretchEnd& at = out.end;
  FrameTimings scratch;
  for (auto it = c.depth.rbegin(); it != c.depth.rend(); ++it) {
    const std::size_t i = it->first;
    if (i >= at.index) continue;  // the recovering frames' own, kept for restart_pending()
    if (i + 1 != at.index || i <= c.end.anchor) break;
    const Eigen::Isometry3d& dead = trajectory[i].T_world_camera;
    const Eigen::Isometry3d seed = at.corrected * at.estimate.inverse() * dead;
    // Where dead reckoning put frame i before partial ICP moved it, if it did: the frames
    // before reach it by dead reckoning alone, so the correction left there is measured from it.
    Eigen::Isometry3d dead_reckoned = dead;
    if (const PartialFrame* partial = find_partial(c.end.fixed, i)) {
      dead_reckoned.translation() -= partial->moved;
      dead_reckoned.linear() = exp_so3(-partial->turned) * dead.linear();
    }
    const DepthView kept = it->second.view();
    IMUFUSION_RETURN_IF_ERROR(model.load_frame(kept, scratch));
    out.moved_reference = true;
    auto placed = model.place(kept, seed, scratch);
    if (!placed) return placed.error();
    // With the gyroscope, a frame placed where the relocalization search would place it: one
    // whose position is fixed while a rotation is not (the view leaves a wall) counts.
    if (c.inertial && !placed->icp.reliable() &&
        fixes_position(placed->icp.quality, model.reliability(kept), max_translation_condition_))
      placed->icp.verdict = IcpVerdict::kReliable;
    if (!placed->icp.reliable() || !placed->icp.quality.converged) break;
    // Without the IMU the seed is the next frame's pose unmoved: one that settled farther from
    // it than a recovering frame may (recovery.agreement_distance) slid onto another stretch of
    // the model in a quick turn.
    const double limit = recovery_.agreement_distance;
    if (!c.inertial && limit > 0 &&
        (placed->T_world_camera.translation() - seed.translation()).norm() > limit)
      break;
    at.index = i;
    at.estimate = dead_reckoned;
    at.corrected = placed->T_world_camera;
    out.placed.emplace_back(i, at.corrected);
  }
  return out;
}

// See Reconstructor::trajectory().
// `placed`: the frames the retrack placed (c.index - 1 and down, newest first), each measuring
// the error there with smoothing.retracked_frame_sigma; they keep their placed poses. Empty: `c`
// ends at the oldest frame placed.
void LossRecovery::correct_stretch(const StretchEnd& c, const Placed& placed,
                                   Trajectory& trajectory) const {
  const std::size_t first_placed = c.index - placed.size();
  const double span = trajectory[c.index].timestamp - trajectory[c.anchor].timestamp;
  if (!(span > 0)) return;
  const StretchCorrection end = end_error(c);
  const std::vector<StretchCorrection> corrections = drift_corrections(
      stretch_frames(c, placed, trajectory), span, end.translation, end.rotation, c.prior);
  for (std::size_t i = c.anchor + 1; i < first_placed; ++i) {
    const StretchCorrection& correction = corrections[i - c.anchor - 1];
    Eigen::Isometry3d& T = trajectory[i].T_world_camera;
    T.linear() = exp_so3(correction.rotation) * T.linear();
    T.translation() += correction.translation;
  }
}

// The velocity error (world) dead reckoning carried to the end of the stretch `c`, which ends
// at `end_time` (s), under the drift model; none where the end error is not a drift the model
// explains (drift_end_velocity).
std::optional<Eigen::Vector3d> LossRecovery::end_velocity_error(
    const StretchEnd& c, double end_time, const Trajectory& trajectory) const {
  const StretchCorrection end = end_error(c);
  return drift_end_velocity(stretch_frames(c, {}, trajectory),
                            end_time - trajectory[c.anchor].timestamp, end.translation,
                            end.rotation, c.prior);
}

// The error the stretch's end shows: truth (where ICP placed it) - estimate (dead reckoning).
StretchCorrection LossRecovery::end_error(const StretchEnd& c) {
  return {c.corrected.translation() - c.estimate.translation(),
          log_so3(c.corrected.linear() * c.estimate.linear().transpose())};
}

// The frames strictly inside the stretch `c`, for drift_corrections (see correct_stretch).
std::vector<StretchFrame> LossRecovery::stretch_frames(const StretchEnd& c, const Placed& placed,
                                                       const Trajectory& trajectory) const {
  const std::size_t first_placed = c.index - placed.size();
  const double t0 = trajectory[c.anchor].timestamp;
  std::vector<StretchFrame> frames;
  for (std::size_t i = c.anchor + 1; i < c.index; ++i) {
    StretchFrame f;
    f.s = trajectory[i].timestamp - t0;
    f.R_world_camera = trajectory[i].T_world_camera.linear();
    if (const PartialFrame* fixed = find_partial(c.fixed, i)) {
      f.fixed = fixed->fixed;
      f.turned = fixed->turned;
      if (fixed->measured) {
        f.moved = fixed->moved;
        f.moved_sigma = smoothing_.partial_move_sigma;
      }
    }
    if (i >= first_placed) {
      f.observed =
          placed[c.index - 1 - i].second.translation() - trajectory[i].T_world_camera.translation();
      f.observed_sigma = smoothing_.retracked_frame_sigma;
    }
    frames.push_back(f);
  }
  return frames;
}

// The inertial estimates as the drift model's prior; none without the IMU.
DriftPrior LossRecovery::drift_prior(const InertialNavigator* navigator) const {
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
    const double scale2 = smoothing_.gravity_sigma_scale * smoothing_.gravity_sigma_scale;
    prior.gravity_bias_covariance.topLeftCorner<3, 3>().diagonal().setConstant(
        scale2 * s.gravity_sigma.squaredNorm() / 3);
    prior.gravity_bias_covariance.bottomRightCorner<3, 3>().diagonal().setConstant(
        scale2 * s.accel_bias_sigma.squaredNorm() / 3);
  }
  prior.gyro_bias_sigma =
      smoothing_.gyro_bias_sigma_scale * s.gyro_bias_sigma.norm() / std::sqrt(3.0);
  prior.gyro_noise_density = gyro_noise_density_;
  return prior;
}

void LossRecovery::describe(StateArchive& archive) {
  archive(constrained_time_, constrained_index_, constrained_prior_, partial_, lost_depth_,
          pending_);
}

void LossRecovery::PartialFrame::describe(StateArchive& archive) {
  archive(index, fixed, moved, turned, measured);
}

void LossRecovery::DepthCopy::describe(StateArchive& archive) {
  archive(layout, bytes);
  const std::size_t expected = layout.pixel_bytes() *
                               static_cast<std::size_t>(std::max(layout.width, 0)) *
                               static_cast<std::size_t>(std::max(layout.height, 0));
  if (archive.reading() && bytes.size() != expected)
    archive.fail("a kept depth image of " + std::to_string(bytes.size()) + " bytes for " +
                 std::to_string(layout.width) + "x" + std::to_string(layout.height));
}

void LossRecovery::StretchEnd::describe(StateArchive& archive) {
  archive(anchor, index, estimate, corrected, prior, fixed);
}

void LossRecovery::PendingCorrection::describe(StateArchive& archive) {
  archive(end, depth, inertial);
}

}  // namespace imufusion
