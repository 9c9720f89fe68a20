#pragma once
// Helpers shared by the evaluation sources; not part of the public API.

#include <string>

#include "imufusion/eval.hpp"

namespace imufusion::eval_internal {

/// First and last timestamp (seconds) of a non-empty trajectory, in any order of poses.
TimeSpan time_span(const Trajectory& trajectory);

/// "N poses spanning A .. B s" (6 decimals), or "no poses".
std::string describe_span(const Trajectory& trajectory);

/// Why too few poses matched, for a person: both trajectories' sizes and spans, and whether the
/// spans are disjoint (the usual sign of a clock offset or of files from different recordings).
std::string describe_mismatch(const Trajectory& gt, const Trajectory& est);

}  // namespace imufusion::eval_internal
