#include <algorithm>
#include <cstdio>
#include <string>

#include "eval/eval_internal.hpp"

namespace imufusion::eval_internal {
namespace {

std::string seconds(double t) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", t);
  return buffer;
}

}  // namespace

TimeSpan time_span(const Trajectory& trajectory) {
  TimeSpan span{trajectory.front().timestamp, trajectory.front().timestamp};
  for (const StampedPose& pose : trajectory) {
    span.begin = std::min(span.begin, pose.timestamp);
    span.end = std::max(span.end, pose.timestamp);
  }
  return span;
}

std::string describe_span(const Trajectory& trajectory) {
  if (trajectory.empty()) return "no poses";
  const TimeSpan span = time_span(trajectory);
  return std::to_string(trajectory.size()) + " poses spanning " + seconds(span.begin) + " .. " +
         seconds(span.end) + " s";
}

std::string describe_mismatch(const Trajectory& gt, const Trajectory& est) {
  std::string text =
      "ground truth has " + describe_span(gt) + ", estimate has " + describe_span(est);
  if (gt.empty() || est.empty()) return text;
  const TimeSpan g = time_span(gt);
  const TimeSpan e = time_span(est);
  if (e.begin > g.end) {
    text += "; the estimate starts " + seconds(e.begin - g.end) +
            " s after the ground truth ends (a clock offset?)";
  } else if (e.end < g.begin) {
    text += "; the estimate ends " + seconds(g.begin - e.end) +
            " s before the ground truth starts (a clock offset?)";
  }
  return text;
}

}  // namespace imufusion::eval_internal
