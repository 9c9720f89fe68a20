#include <algorithm>
#include <cmath>
#include <string_view>

#include "core/state_archive.hpp"
#include "imufusion/tracking.hpp"

namespace imufusion {

const char* to_string(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kTracking:
      return "tracking";
    case TrackingStatus::kLost:
      return "lost";
    case TrackingStatus::kRecovering:
      return "recovering";
  }
  return "unknown";
}

const char* to_string(PoseSource source) {
  switch (source) {
    case PoseSource::kInitial:
      return "initial";
    case PoseSource::kIcp:
      return "icp";
    case PoseSource::kIcpPartial:
      return "icp_partial";
    case PoseSource::kDeadReckoning:
      return "dead_reckoning";
    case PoseSource::kKnown:
      return "known";
  }
  return "unknown";
}

namespace {

double median(std::deque<double> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// Appends `value`, keeping the newest `window` (> 0) values.
void keep_last(std::deque<double>& values, double value, int window) {
  values.push_back(value);
  while (values.size() > static_cast<std::size_t>(window)) values.pop_front();
}

}  // namespace

void PairingReference::add(double inlier_fraction, double pixel_fraction) {
  if (config_.pairing_window <= 0) return;
  keep_last(inlier_, inlier_fraction, config_.pairing_window);
  keep_last(pixel_, pixel_fraction, config_.pairing_window);
}

void PairingReference::add_residual(double residual_per_weight, double noise_variance) {
  if (config_.pairing_window <= 0 || config_.residual_ratio <= 0) return;
  if (!(residual_per_weight > 0) || !(noise_variance > 0)) return;
  const double ratio = residual_per_weight / noise_variance;
  if (!std::isfinite(ratio)) return;
  keep_last(residual_, ratio, config_.pairing_window);
}

double PairingReference::residual_limit(double fixed, double widened, double noise_variance) const {
  if (residual_.empty() || !(noise_variance > 0)) return widened;
  const double shown = config_.residual_ratio * median(residual_) * noise_variance;
  return std::clamp(shown, fixed, std::max(fixed, widened));
}

void PairingReference::apply(double& min_inlier_fraction, double& min_pixel_fraction) const {
  const double floor = config_.pairing_floor;
  const auto lowered = [&](double base, const std::deque<double>& seen) {
    if (seen.empty()) return base;
    return std::min(base, std::max(floor, config_.pairing_ratio * median(seen)));
  };
  min_inlier_fraction = lowered(min_inlier_fraction, inlier_);
  min_pixel_fraction = lowered(min_pixel_fraction, pixel_);
}

void PairingReference::reset() {
  inlier_.clear();
  pixel_.clear();
  residual_.clear();
}

void PredictionCalibration::add(double chi2) {
  if (config_.prediction_window <= 0 || !(chi2 >= 0) || !std::isfinite(chi2)) return;
  const double unit = chi2 * scale() * scale();
  keep_last(chi2_, unit, config_.prediction_window);
}

double PredictionCalibration::scale() const {
  constexpr double kMedianChi2Of6 = 5.348;  // the median of chi^2 with 6 degrees of freedom
  if (chi2_.empty()) return 1;
  return std::sqrt(std::max(1.0, median(chi2_) / kMedianChi2Of6));
}

std::optional<TrackingStatus> parse_tracking_status(std::string_view name) {
  for (auto s : {TrackingStatus::kTracking, TrackingStatus::kLost, TrackingStatus::kRecovering})
    if (name == to_string(s)) return s;
  return std::nullopt;
}

std::optional<PoseSource> parse_pose_source(std::string_view name) {
  for (auto s : {PoseSource::kInitial, PoseSource::kIcp, PoseSource::kIcpPartial,
                 PoseSource::kDeadReckoning, PoseSource::kKnown})
    if (name == to_string(s)) return s;
  return std::nullopt;
}

TrackingDecision TrackingStateMachine::start() {
  started_ = true;
  status_ = TrackingStatus::kTracking;
  good_frames_ = 0;
  return {TrackingStatus::kTracking, PoseSource::kInitial, true, 0, false};
}

TrackingDecision TrackingStateMachine::step(bool icp_reliable, bool converged, bool icp_partial,
                                            bool partial_may_fuse, bool relocalized) {
  if (!started_) return start();
  const PoseSource lost_source = icp_partial ? PoseSource::kIcpPartial : PoseSource::kDeadReckoning;
  if (status_ == TrackingStatus::kTracking) {
    if (icp_reliable) return {TrackingStatus::kTracking, PoseSource::kIcp, true, 0, false};
    if (icp_partial && partial_may_fuse)
      return {TrackingStatus::kTracking, PoseSource::kIcpPartial, true, 0, false};
    status_ = TrackingStatus::kLost;
    return {TrackingStatus::kLost, lost_source, false, 0, false};
  }
  // Lost or recovering: only a reliable alignment that has settled counts towards recovery. While
  // recovering, a reliable frame that has not settled within its iterations neither counts nor
  // breaks the count; an unreliable one does.
  if (status_ == TrackingStatus::kRecovering && icp_reliable && !converged)
    return {TrackingStatus::kRecovering, PoseSource::kIcp, false, good_frames_, false};
  if (!(icp_reliable && converged)) {
    status_ = TrackingStatus::kLost;
    good_frames_ = 0;
    return {TrackingStatus::kLost, icp_reliable ? PoseSource::kDeadReckoning : lost_source, false,
            0, false};
  }
  // A relocalized lost frame counts as the frames the search's confirmation stands for.
  const int credit =
      status_ == TrackingStatus::kLost && relocalized
          ? std::max(config_.recovery_frames - config_.relocalized_recovery_frames + 1, 1)
          : 1;
  good_frames_ = std::min(good_frames_ + credit, std::max(config_.recovery_frames, 1));
  if (good_frames_ >= config_.recovery_frames) {
    status_ = TrackingStatus::kTracking;
    const int counted = good_frames_;
    good_frames_ = 0;
    return {TrackingStatus::kTracking, PoseSource::kIcp, true, counted, true};
  }
  status_ = TrackingStatus::kRecovering;
  return {TrackingStatus::kRecovering, PoseSource::kIcp, false, good_frames_, false};
}

void TrackingStateMachine::restart_recovery() {
  if (started_ && status_ == TrackingStatus::kRecovering) good_frames_ = 0;
}

void TrackingStateMachine::reset() {
  started_ = false;
  status_ = TrackingStatus::kTracking;
  good_frames_ = 0;
}

void PairingReference::describe(StateArchive& archive) { archive(inlier_, pixel_, residual_); }

void PredictionCalibration::describe(StateArchive& archive) { archive(chi2_); }

void TrackingStateMachine::describe(StateArchive& archive) {
  archive(started_, status_, good_frames_);
}

}  // namespace imufusion
