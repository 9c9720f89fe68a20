#include <algorithm>
#include <string_view>

#include "imufusion/tracking.hpp"

namespace imufusion {

const char* to_string(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kTracking: return "tracking";
    case TrackingStatus::kLost: return "lost";
    case TrackingStatus::kRecovering: return "recovering";
  }
  return "unknown";
}

const char* to_string(PoseSource source) {
  switch (source) {
    case PoseSource::kInitial: return "initial";
    case PoseSource::kIcp: return "icp";
    case PoseSource::kIcpPartial: return "icp_partial";
    case PoseSource::kDeadReckoning: return "dead_reckoning";
    case PoseSource::kKnown: return "known";
  }
  return "unknown";
}

std::optional<TrackingStatus> parse_tracking_status(std::string_view name) {
  for (auto s : {TrackingStatus::kTracking, TrackingStatus::kLost, TrackingStatus::kRecovering})
    if (name == to_string(s)) return s;
  return std::nullopt;
}

std::optional<PoseSource> parse_pose_source(std::string_view name) {
  for (auto s : {PoseSource::kInitial, PoseSource::kIcp, PoseSource::kIcpPartial, PoseSource::kDeadReckoning,
                 PoseSource::kKnown})
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
                                            bool partial_may_fuse) {
  if (!started_) return start();
  const PoseSource lost_source = icp_partial ? PoseSource::kIcpPartial : PoseSource::kDeadReckoning;
  if (status_ == TrackingStatus::kTracking) {
    if (icp_reliable) return {TrackingStatus::kTracking, PoseSource::kIcp, true, 0, false};
    if (icp_partial && partial_may_fuse) return {TrackingStatus::kTracking, PoseSource::kIcpPartial, true, 0, false};
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
    return {TrackingStatus::kLost, icp_reliable ? PoseSource::kDeadReckoning : lost_source, false, 0, false};
  }
  good_frames_ = std::min(good_frames_ + 1, std::max(config_.recovery_frames, 1));
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

}  // namespace imufusion
