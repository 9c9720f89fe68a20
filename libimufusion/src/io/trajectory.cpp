#include "imufusion/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "io/atomic_file.hpp"
#include "io/text_table.hpp"

namespace imufusion {
namespace {

// |q| may be off 1 by rounding in files written with few decimals (TUM uses 4); more than this
// is a corrupt line, not rounding.
constexpr double kQuaternionNormTolerance = 1e-3;

}  // namespace

Result<Trajectory> read_trajectory(const std::filesystem::path& path) {
  auto lines = io::read_text_table(path);
  if (!lines.ok()) return lines.error();
  Trajectory trajectory;
  trajectory.reserve(lines->size());
  for (const io::TextLine& line : *lines) {
    IMUFUSION_RETURN_IF_ERROR(io::expect_fields(line, 8, path, "timestamp tx ty tz qx qy qz qw"));
    static constexpr const char* kNames[8] = {"timestamp", "tx", "ty", "tz",
                                              "qx",        "qy", "qz", "qw"};
    double values[8];
    for (int i = 0; i < 8; ++i) {
      auto value = io::parse_finite(line.fields[i], path, line.number, kNames[i]);
      if (!value.ok()) return value.error();
      values[i] = *value;
    }
    if (!trajectory.empty() && values[0] <= trajectory.back().timestamp) {
      const bool duplicate = values[0] == trajectory.back().timestamp;
      return make_error(ErrorCode::kParseError,
                        io::where(path, line.number) + "timestamp " + line.fields[0] +
                            (duplicate ? " is a duplicate of the previous line's"
                                       : " is not after the previous line's " +
                                             io::format_exact(trajectory.back().timestamp)));
    }
    Eigen::Quaterniond q(values[7], values[4], values[5], values[6]);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
      return make_error(ErrorCode::kParseError, io::where(path, line.number) +
                                                    "quaternion (qx qy qz qw) has norm " +
                                                    std::to_string(norm) + ", expected 1");
    }
    q.normalize();
    StampedPose pose;
    pose.timestamp = values[0];
    pose.T_world_camera.linear() = q.toRotationMatrix();
    pose.T_world_camera.translation() = Eigen::Vector3d(values[1], values[2], values[3]);
    trajectory.push_back(pose);
  }
  return trajectory;
}

std::string format_tum_line(const StampedPose& pose) {
  const Eigen::Quaterniond q(pose.T_world_camera.rotation());
  const Eigen::Vector3d& t = pose.T_world_camera.translation();
  char buffer[256];
  std::snprintf(buffer, sizeof(buffer), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", pose.timestamp,
                t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  return buffer;
}

Status write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                        const std::string& header_comment) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const StampedPose& pose = trajectory[i];
    if (!std::isfinite(pose.timestamp) || !pose.T_world_camera.matrix().allFinite()) {
      return make_error(ErrorCode::kInvalidArgument,
                        path.string() + ": pose " + std::to_string(i) + " is not finite");
    }
  }
  std::string content;
  if (!header_comment.empty()) {
    std::size_t start = 0;
    while (start <= header_comment.size()) {
      std::size_t end = header_comment.find('\n', start);
      if (end == std::string::npos) end = header_comment.size();
      content += "# " + header_comment.substr(start, end - start) + "\n";
      start = end + 1;
    }
  }
  content += "# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose& pose : trajectory) content += format_tum_line(pose) + "\n";
  return io::write_text_atomically(path, content);
}

const StampedPose* find_pose(const Trajectory& trajectory, double t, double max_difference) {
  auto it = std::lower_bound(trajectory.begin(), trajectory.end(), t,
                             [](const StampedPose& p, double x) { return p.timestamp < x; });
  const StampedPose* best = nullptr;
  for (auto c : {it, it == trajectory.begin() ? it : it - 1}) {
    if (c == trajectory.end()) continue;
    if (best == nullptr || std::abs(c->timestamp - t) < std::abs(best->timestamp - t)) best = &*c;
  }
  return best != nullptr && std::abs(best->timestamp - t) <= max_difference ? best : nullptr;
}

}  // namespace imufusion
