// RelocalizationDriver: when a lost frame searches the model, the search and its candidates' ICP.

#include "scan/relocalization.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "scan/clock.hpp"

namespace imufusion {

RelocalizationDriver::RelocalizationDriver(const ReconstructorConfig& config)
    : config_(config.relocalization),
      icp_reach_(config.icp.max_distance[static_cast<std::size_t>(config.preprocess.levels - 1)]),
      coarse_level_(config.preprocess.levels - 1),
      max_depth_(config.preprocess.max_depth),
      max_speed_(config.inertial.max_speed) {}

void RelocalizationDriver::reset() {
  field_current_ = coarse_current_ = false;
  views_.clear();
  lost_frames_since_attempt_ = 0;
  forget_ambiguity();
}

// A loss ended or the scan restarted: nothing waits for confirmation.
void RelocalizationDriver::forget_ambiguity() {
  unconfirmed_correction_.reset();
  ambiguous_alternatives_.clear();
  confirm_next_ = false;
  near_fit_ = false;
}

Result<RelocalizationDriver::Outcome> RelocalizationDriver::on_frame(const Frame& frame,
                                                                     const DepthView& depth,
                                                                     ModelAligner& model,
                                                                     FrameTimings& timings) {
  Outcome out;
  out.long_loss = long_loss(frame);
  if (!should_search(frame, out.long_loss)) return out;
  auto found = search(frame, depth, model, timings);
  if (!found) return found.error();
  out.found = std::move(*found);
  return out;
}

// How far dead reckoning may have drifted in `lost_seconds` since the last fully constrained
// frame (m), from the coarsest ICP level's reach up to relocalization.max_radius.
double RelocalizationDriver::drift_radius(double lost_seconds) const {
  return std::min(
      config_.max_radius,
      std::max<double>(icp_reach_, 0.5 * config_.drift_acceleration * lost_seconds * lost_seconds));
}

// A loss long enough that the dead-reckoned seed may lie beyond ICP's reach: an alignment
// from it can settle on the wrong stretch of a weakly constrained view, so recovery must be
// confirmed by the relocalization search.
bool RelocalizationDriver::long_loss(const Frame& frame) const {
  if (!config_.enabled || !frame.lost) return false;
  const double lost_seconds = frame.timestamp - frame.constrained_time;
  if (frame.rotation_from_imu) return drift_radius(lost_seconds) > icp_reach_;
  // Without the gyroscope nothing follows the camera: it may be anywhere a hand-held camera
  // goes (inertial.max_speed) since the loss, and only the search over orientations confirms.
  return config_.turn_step_deg > 0 && reach(lost_seconds) > icp_reach_;
}

// Whether this frame searches for its pose: every relocalization.interval lost frames, the
// lost frame after a search whose best fit waits for confirmation or nearly constrained every
// direction, with the gyroscope a lost frame whose view fixes more than a plane's three
// directions (it is leaving a wall: a fit that fixes the position may be there), and whenever
// ICP from the seed would end a long loss.
bool RelocalizationDriver::should_search(const Frame& frame, bool long_loss) {
  if (!frame.lost) {
    lost_frames_since_attempt_ = 0;
    forget_ambiguity();
    return false;
  }
  if (!config_.enabled || !(frame.rotation_from_imu || config_.turn_step_deg > 0)) return false;
  if (frame.icp_reliable) return long_loss;
  const bool again = confirm_next_ || near_fit_ ||
                     (frame.rotation_from_imu && frame.partial_directions > kPlaneDirections);
  confirm_next_ = near_fit_ = false;
  if (++lost_frames_since_attempt_ < config_.interval && !again) return false;
  lost_frames_since_attempt_ = 0;
  return true;
}

// The distance field of the model's surface within a search's reach of `anchor` (world, m):
// an unbounded scene costs no more than a room. With `coarse`, also the field at twice the cell.
Status RelocalizationDriver::build_field(ModelAligner& model, const Eigen::Vector3d& anchor,
                                         bool coarse) {
  auto snapshot = model.model_snapshot();
  if (!snapshot) return snapshot.error();
  std::vector<Eigen::Vector3d> surface = volume_surface_points(*snapshot);
  const double cutoff = 4 * config_.cell;
  const double reach = config_.max_radius + max_depth_ + cutoff;
  std::erase_if(surface, [&](const Eigen::Vector3d& p) {
    return (p - anchor).cwiseAbs().maxCoeff() > reach;
  });
  field_ = SurfaceDistanceField(surface, config_.cell, cutoff);
  field_current_ = true;
  if (coarse) coarse_field_ = SurfaceDistanceField(surface, 2 * config_.cell, cutoff);
  coarse_current_ = coarse;
  return {};
}

void RelocalizationDriver::note_view(const Eigen::Matrix3d& R_world_camera) {
  if (config_.turn_step_deg <= 0) return;
  const Eigen::Quaterniond q(R_world_camera);
  const double apart = 0.5 * config_.turn_step_deg * std::numbers::pi / 180;
  if (std::none_of(views_.begin(), views_.end(),
                   [&](const Eigen::Quaterniond& v) { return v.angularDistance(q) < apart; }))
    views_.push_back(q);
}

// Without the gyroscope: the 2 x relocalization.candidates best distinct places over
// orientations turned about the estimate's vertical (camera y) all the way round and tilted about
// its camera x, one step up and down, and each fused frame's orientation beyond those (a camera
// that turns back to the model sees it much as it was scanned), swept on the coarse field with a
// subset of the points; each place's best orientation, its translation refined on the fine
// field. Twice the candidates: a fit elsewhere is what rejects a wrong place.
std::vector<RelocalizationDriver::Oriented> RelocalizationDriver::turned_candidates(
    const std::vector<Eigen::Vector3d>& points, const Eigen::Matrix3d& R_estimate,
    const Eigen::Vector3d& center, double radius) const {
  constexpr std::size_t kSweepPoints = 200;  // the sweep's cost is linear in them
  const std::vector<Eigen::Vector3d> few = spread_subset(points, kSweepPoints);
  const double step = config_.turn_step_deg * std::numbers::pi / 180;
  const int turns = std::max(1, static_cast<int>(std::lround(2 * std::numbers::pi / step)));
  const Eigen::Vector3d up = R_estimate.col(1), side = R_estimate.col(0);
  std::vector<Eigen::Matrix3d> orientations;
  for (int k = 0; k < turns; ++k)
    for (int tilt = -1; tilt <= 1; ++tilt)
      orientations.push_back((Eigen::AngleAxisd(2 * std::numbers::pi * k / turns, up) *
                              Eigen::AngleAxisd(tilt * step, side))
                                 .toRotationMatrix() *
                             R_estimate);
  // A fused frame's orientation within half a step of the sweep's adds nothing to it.
  const std::size_t swept_count = orientations.size();
  for (const Eigen::Quaterniond& v : views_) {
    const Eigen::Matrix3d R_view = v.toRotationMatrix();
    const auto covered = [&](const Eigen::Matrix3d& R) {
      return Eigen::AngleAxisd(R.transpose() * R_view).angle() < 0.5 * step;
    };
    if (std::none_of(orientations.begin(), orientations.begin() + swept_count, covered))
      orientations.push_back(R_view);
  }
  std::vector<Oriented> swept;
  for (const Eigen::Matrix3d& R : orientations)
    for (const TranslationCandidate& c :
         coarse_field_.search(few, R, center, radius, 2 * config_.candidates))
      swept.push_back({R, c});
  std::sort(swept.begin(), swept.end(),
            [](const Oriented& a, const Oriented& b) { return a.at.cost < b.at.cost; });
  const double apart = 2 * coarse_field_.cell();
  std::vector<Oriented> out;
  for (const Oriented& o : distinct_places(swept, 2 * config_.candidates, apart,
                                           [](const Oriented& x) { return x.at.translation; })) {
    const std::vector<TranslationCandidate> refined =
        field_.search(points, o.R_world_camera, o.at.translation, apart, 1);
    if (!refined.empty()) out.push_back({o.R_world_camera, refined.front()});
  }
  return out;
}

// The translation search (without the gyroscope, over orientations too) and ICP from its best
// candidates; the reliable, converged alignment with the lowest residual per weight, if it is
// the only place the frame fits: when another candidate's ICP also passes every test but the
// condition number somewhere else (more than two cells away), the view is ambiguous (a wall and
// the floor slide along their common line) and nothing is accepted.
Result<std::optional<ModelAligner::Placement>> RelocalizationDriver::search(const Frame& frame,
                                                                            const DepthView& depth,
                                                                            ModelAligner& model,
                                                                            FrameTimings& timings) {
  const auto t0 = Clock::now();
  // Without the gyroscope the orientation is searched too, and the camera may be anywhere a
  // hand-held scanner goes since the loss; a fit beyond that is no place for it, with or without.
  const bool turning = !frame.rotation_from_imu;
  if (!field_current_ || (turning && !coarse_current_))
    IMUFUSION_RETURN_IF_ERROR(build_field(model, frame.lost_at, turning));
  const double lost_seconds = frame.timestamp - frame.constrained_time;
  const double reachable = reach(lost_seconds);  // m: how far the camera can have gone since
  const double radius = turning ? std::min(config_.max_radius, std::max(icp_reach_, reachable))
                                : drift_radius(lost_seconds);
  auto all_points = model.frame_points(coarse_level_);
  if (!all_points) return all_points.error();
  constexpr std::size_t kMaxPoints = 800;  // enough for a chamfer fit; the search is linear in it
  // Spread over the normals' directions: a view that is mostly wall keeps every point of what
  // fixes the slide along it, which an even spread over the pixels would drown in wall points.
  const std::vector<Eigen::Vector3d> points =
      normal_space_subset(all_points->points, all_points->normals, kMaxPoints);
  const Eigen::Isometry3d& T_estimate = frame.T_world_estimate;
  std::vector<Oriented> candidates;
  if (turning) {
    candidates = turned_candidates(points, T_estimate.linear(), frame.lost_at, radius);
  } else {
    std::vector<TranslationCandidate> found = field_.search(
        points, T_estimate.linear(), T_estimate.translation(), radius, config_.candidates);
    // Dead reckoning may have drifted beyond the search, while a hand-held camera that turns
    // back to the scanned model is seldom far from where the scan was lost: search there too.
    if ((frame.lost_at - T_estimate.translation()).norm() > config_.cell) {
      found = merge_candidates(
          found,
          field_.search(points, T_estimate.linear(), frame.lost_at, radius, config_.candidates),
          config_.candidates, 2 * config_.cell);
    }
    // The estimate itself and, while a fit waits for confirmation, the estimate at that fit's
    // correction, each unless a candidate is within a cell of it: where the gyro and the
    // partial frames put the camera, and where the last search found it, are the likeliest
    // places, and the field's coarse grid may miss them.
    std::vector<Eigen::Vector3d> starts{T_estimate.translation()};
    if (unconfirmed_correction_)
      starts.push_back(T_estimate.translation() + *unconfirmed_correction_);
    for (const Eigen::Vector3d& start : starts) {
      if (std::none_of(found.begin(), found.end(), [&](const TranslationCandidate& c) {
            return (c.translation - start).norm() <= config_.cell;
          }))
        candidates.push_back({T_estimate.linear(), {.translation = start, .near_fraction = 1}});
    }
    for (const TranslationCandidate& c : found) candidates.push_back({T_estimate.linear(), c});
  }
  std::optional<ModelAligner::Placement> best;
  IcpReliabilityThresholds plausible = model.reliability(depth);
  const double max_condition = plausible.max_condition;
  plausible.max_condition = std::numeric_limits<double>::infinity();
  std::vector<Fit> fits;           // where the frame fits but for the condition number
  std::vector<Fit> placed_at;      // where it fits in every direction (reliable)
  FrameTimings candidate_timings;  // kept out of the frame's ICP and raycast times
  for (const auto& [R_candidate, c] : candidates) {
    if (c.near_fraction < plausible.min_inlier_fraction) continue;
    Eigen::Isometry3d T_candidate = Eigen::Isometry3d::Identity();
    T_candidate.linear() = R_candidate;
    T_candidate.translation() = c.translation;
    // No IMU prediction: the full six-direction solve, which a wall alone cannot pass.
    auto placed = model.place(depth, T_candidate, candidate_timings);
    if (!placed) return placed.error();
    // ICP may slide a fit along a weak direction to where the camera cannot be: neither a place
    // nor a rival.
    if ((placed->T_world_camera.translation() - frame.lost_at).norm() > reachable) continue;
    IcpResult& icp = placed->icp;
    Fit fit{placed->T_world_camera.translation(), icp.quality.residual_per_weight,
            icp.quality.inlier_fraction};
    if (icp.quality.iterations > 0 && judge_icp(icp.quality, plausible, nullptr)) {
      const bool position_fixed =
          !turning && fixes_position(icp.quality, plausible, config_.max_translation_condition);
      fit.places = !turning && (icp.quality.condition <= max_condition || position_fixed);
      fits.push_back(fit);
      // A fit that only the condition number fails, narrowly: the next frame searches again
      // (at the gyro's orientation; a sweep over orientations finds such fits anywhere).
      near_fit_ =
          near_fit_ || (!turning && icp.quality.condition > max_condition &&
                        icp.quality.condition <= config_.near_fit_condition_factor * max_condition);
      // Started at the gyroscope's orientation, a fit that fixes the position places the frame.
      if (!icp.reliable() && position_fixed) {
        icp.verdict = IcpVerdict::kReliable;
        icp.reason.clear();
      }
    }
    if (!icp.reliable() || !icp.quality.converged) continue;
    // Without the gyroscope, a fit that only just fixes every direction is no place for the
    // frame (relocalization.turned_condition_factor); it still counts as a rival above.
    if (turning && icp.quality.condition > config_.turned_condition_factor * max_condition)
      continue;
    placed_at.push_back(fit);
    // The best fit: one that fixes every direction before one placed by its translation alone,
    // then the lowest residual per weight.
    const bool full = icp.quality.condition <= max_condition;
    const bool best_full = best && best->icp.quality.condition <= max_condition;
    if (!best || (full && !best_full) ||
        (full == best_full &&
         icp.quality.residual_per_weight < best->icp.quality.residual_per_weight))
      best = std::move(*placed);
  }
  const double apart = 2 * config_.cell;
  // A fit elsewhere that explains the frame about as well as the best one: its residual per
  // weight within relocalization.rival_residual_ratio of the best's (0: any fit elsewhere), and
  // its inlier fraction at least relocalization.rival_inlier_ratio of the best's. Where the
  // noise, not the place, sets the residual, a fit of part of the view (a wall that pairs
  // elsewhere) has the best's residual but pairs less of the view. With the gyroscope a rival
  // must be a place for the frame too (every direction fixed, or its position): a fit whose
  // translation slides (a view that is mostly wall) stops wherever along the slide the search
  // started it, and pairs the wall there with a lower residual than the fit that also pairs what
  // fixes the slide.
  const auto rival = [&](const Fit& f) {
    const IcpQuality& b = best->icp.quality;
    return (turning || f.places) && (f.at - best->T_world_camera.translation()).norm() > apart &&
           (config_.rival_residual_ratio <= 0 ||
            f.residual_per_weight <= config_.rival_residual_ratio * b.residual_per_weight) &&
           f.inlier_fraction >= config_.rival_inlier_ratio * b.inlier_fraction;
  };
  // Within two cells, and `moved` (m) beyond them.
  const auto near = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double moved = 0) {
    return (a - b).norm() <= apart + moved;
  };
  // Where the best fit puts the frame relative to its estimate (world).
  const Eigen::Vector3d correction =
      best ? Eigen::Vector3d(best->T_world_camera.translation() - T_estimate.translation())
           : Eigen::Vector3d::Zero();
  if (turning) {
    // Free to turn, a view fits a room's like-looking corners and walls: a rival anywhere else
    // rejects the best one, and the only fit takes the frame once the next search, from the next
    // lost frame, puts its only fit at the same place. The estimate stays where the scan was
    // lost while the camera moves on, so the same place is within two cells and what a hand-held
    // camera moves between the two frames (inertial.max_speed). An only fit that the next
    // search does not confirm has the lost frame after it search again.
    const bool unique = best && std::none_of(fits.begin(), fits.end(), rival);
    const bool confirmed =
        unique && unconfirmed_correction_ &&
        near(correction, *unconfirmed_correction_, reach(frame.timestamp - unconfirmed_time_));
    confirm_next_ = unique && !confirmed;
    if (unique) {
      unconfirmed_correction_ = correction;
      unconfirmed_time_ = frame.timestamp;
    } else {
      unconfirmed_correction_.reset();
    }
    ambiguous_alternatives_.clear();
    if (!confirmed) best.reset();
  } else if (best && std::any_of(fits.begin(), fits.end(), rival)) {
    // An ambiguous view is accepted when the last search of this loss, from another view, put
    // its best fit at the same correction of the estimate and no reliable fit where this one has
    // another: the coincidences of a view (a wall's slide, a stretch of the model not yet
    // scanned) change from view to view; the camera's place and a repeated structure do not. A
    // fit that is only ill-conditioned barely moves along its slide from where the search
    // started it, so its place says nothing either way.
    std::vector<Eigen::Vector3d> others;  // the reliable fits elsewhere, as corrections
    for (const Fit& f : placed_at)
      if (rival(f)) others.push_back(f.at - T_estimate.translation());
    const bool confirmed =
        unconfirmed_correction_ && near(correction, *unconfirmed_correction_) &&
        std::none_of(others.begin(), others.end(), [&](const Eigen::Vector3d& a) {
          return std::any_of(ambiguous_alternatives_.begin(), ambiguous_alternatives_.end(),
                             [&](const Eigen::Vector3d& b) { return near(a, b); });
        });
    // The first ambiguous search of a run has the next lost frame confirm it; a confirmation
    // that failed waits for the next regular search.
    confirm_next_ = !confirmed && !unconfirmed_correction_;
    unconfirmed_correction_ = correction;
    ambiguous_alternatives_ = std::move(others);
    if (!confirmed) best.reset();
  } else {
    unconfirmed_correction_.reset();
    ambiguous_alternatives_.clear();
  }
  timings.kernels.insert(timings.kernels.end(), candidate_timings.kernels.begin(),
                         candidate_timings.kernels.end());
  timings.relocalize_ms = ms_since(t0);
  return best;
}

void RelocalizationDriver::describe(StateArchive& archive) {
  archive(field_current_, coarse_current_, views_, lost_frames_since_attempt_,
          unconfirmed_correction_, unconfirmed_time_, ambiguous_alternatives_, confirm_next_,
          near_fit_);
  if (archive.reading()) field_ = coarse_field_ = {};
  if (field_current_) archive(field_);
  if (coarse_current_) archive(coarse_field_);
}

}  // namespace imufusion
