#pragma once
// Trajectories in the TUM line format: `timestamp tx ty tz qx qy qz qw`, camera-to-world
// (T_world_camera), metres and seconds; `#` starts a comment line.

#include <filesystem>
#include <string>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Reads a TUM trajectory (e.g. groundtruth.txt). Fails naming file and line on malformed lines,
/// NaN/inf values, a non-unit quaternion (|q| off 1 by more than 1e-3 is an error; smaller
/// deviations are normalized), and timestamps that are not strictly increasing.
Result<Trajectory> read_trajectory(const std::filesystem::path& path);

/// One TUM line (no newline): timestamp with 6 decimals, translation and quaternion with 9.
std::string format_tum_line(const StampedPose& pose);

/// Writes a TUM trajectory atomically (temporary file, then rename), with a header comment.
Status write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                        const std::string& header_comment = "");

/// The pose whose timestamp is nearest t (seconds), when it lies within max_difference; else
/// nullptr. `trajectory` must be sorted by time (read_trajectory guarantees it).
const StampedPose* find_pose(const Trajectory& trajectory, double t, double max_difference = 0.02);

}  // namespace imufusion
