#include <cmath>
#include <cstdio>
#include <utility>

#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"
#include "io/atomic_file.hpp"
#include "io/line_appender.hpp"
#include "io/text_table.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

// Image names carry the stamp with 6 decimals, as the TUM benchmark; the index lines carry the
// exact stamp so that a reader gets back what was written.
std::string stamp_name(const char* folder, double timestamp) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%s/%.6f.png", folder, timestamp);
  return buffer;
}

Status check_stamp(const fs::path& dir, const char* stream, double timestamp, bool has_previous,
                   double previous) {
  if (!std::isfinite(timestamp)) {
    return make_error(ErrorCode::kInvalidArgument,
                      dir.string() + ": " + stream + " timestamp is not finite");
  }
  if (has_previous && !(timestamp > previous)) {
    return make_error(ErrorCode::kInvalidArgument,
                      dir.string() + ": " + stream + " timestamp " + io::format_exact(timestamp) +
                          " is not after the previous one " + io::format_exact(previous));
  }
  return {};
}

std::string join_exact(std::initializer_list<double> values) {
  std::string line;
  for (double value : values) {
    if (!line.empty()) line += ' ';
    line += io::format_exact(value);
  }
  return line;
}

struct IndexLine {
  double timestamp;
  std::string name;
};

constexpr const char* kDepthHeader = "# depth maps\n# timestamp filename\n";
constexpr const char* kColorHeader = "# color images\n# timestamp filename\n";
constexpr const char* kImuHeader = "# timestamp wx wy wz ax ay az  (rad/s, m/s^2, IMU frame)\n";

std::string index_line(const IndexLine& line) {
  return io::format_exact(line.timestamp) + " " + line.name + "\n";
}

std::string imu_line(const ImuSample& m) {
  return join_exact({m.timestamp, m.gyro.x(), m.gyro.y(), m.gyro.z(), m.accel.x(), m.accel.y(),
                     m.accel.z()}) +
         "\n";
}

std::string calibration_text(const Intrinsics& k) {
  if (!k.distorted()) return join_exact({k.fx, k.fy, k.cx, k.cy}) + "\n";
  const auto& d = k.distortion;
  return join_exact({k.fx, k.fy, k.cx, k.cy, d[0], d[1], d[2], d[3], d[4]}) + "\n";
}

std::string imu_to_camera_text(const Eigen::Isometry3d& T_camera_imu) {
  const Eigen::Quaterniond q(T_camera_imu.linear());
  const Eigen::Vector3d& t = T_camera_imu.translation();
  return "# qx qy qz qw tx ty tz  (maps IMU-frame coordinates into the camera frame)\n" +
         join_exact({q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()}) + "\n";
}

}  // namespace

struct SequenceWriter::State {
  fs::path directory;
  bool as_you_go = false;  // Options::write_as_you_go
  std::vector<IndexLine> depth, color;
  std::vector<ImuSample> imu;
  Trajectory ground_truth;
  std::optional<Intrinsics> intrinsics;
  std::optional<Eigen::Isometry3d> T_camera_imu;
  std::vector<std::pair<std::string, std::string>> info;  // in the order set
  int width = 0, height = 0;
  double depth_scale = 0;
  io::LineAppender depth_log, color_log, imu_log;  // write_as_you_go only
  bool imu_forgotten = false;                      // forget_imu() stopped appending to imu.txt

  // info.txt: the values derived from the depth images, then the caller's keys in order.
  Result<std::string> info_text() const;
};

SequenceWriter::SequenceWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}
SequenceWriter::SequenceWriter(SequenceWriter&&) noexcept = default;
SequenceWriter& SequenceWriter::operator=(SequenceWriter&&) noexcept = default;
SequenceWriter::~SequenceWriter() = default;

Result<SequenceWriter> SequenceWriter::create(const fs::path& directory) {
  return create(directory, Options{});
}

Result<SequenceWriter> SequenceWriter::create(const fs::path& directory, const Options& options) {
  std::error_code ec;
  if (fs::exists(directory, ec)) {
    if (!fs::is_directory(directory, ec)) {
      return make_error(ErrorCode::kInvalidArgument,
                        directory.string() + ": exists and is not a directory");
    }
    if (!options.allow_existing && !fs::is_empty(directory, ec)) {
      return make_error(
          ErrorCode::kInvalidArgument,
          directory.string() + ": exists and is not empty (refusing to mix two recordings)");
    }
  }
  for (const fs::path& dir : {directory, directory / "depth", directory / "rgb"}) {
    fs::create_directories(dir, ec);
    if (ec) {
      return make_error(ErrorCode::kIoError,
                        "cannot create directory " + dir.string() + ": " + ec.message());
    }
  }
  auto state = std::make_unique<State>();
  state->directory = directory;
  state->as_you_go = options.write_as_you_go;
  return SequenceWriter(std::move(state));
}

const fs::path& SequenceWriter::directory() const { return state_->directory; }

Status SequenceWriter::add_depth(double timestamp, const DepthImage& image) {
  State& s = *state_;
  IMUFUSION_RETURN_IF_ERROR(check_stamp(s.directory, "depth", timestamp, !s.depth.empty(),
                                        s.depth.empty() ? 0 : s.depth.back().timestamp));
  if (s.depth.empty()) {
    if (!(image.depth_scale > 0) || !std::isfinite(image.depth_scale)) {
      return make_error(ErrorCode::kInvalidArgument, s.directory.string() + ": depth_scale " +
                                                         io::format_exact(image.depth_scale) +
                                                         " must be positive");
    }
    s.width = image.width;
    s.height = image.height;
    s.depth_scale = image.depth_scale;
  } else if (image.width != s.width || image.height != s.height ||
             image.depth_scale != s.depth_scale) {
    return make_error(
        ErrorCode::kInvalidArgument,
        s.directory.string() + ": depth image at " + io::format_exact(timestamp) + " is " +
            std::to_string(image.width) + "x" + std::to_string(image.height) + " scale " +
            io::format_exact(image.depth_scale) + ", the first was " + std::to_string(s.width) +
            "x" + std::to_string(s.height) + " scale " + io::format_exact(s.depth_scale));
  }
  const std::string name = stamp_name("depth", timestamp);
  if (!s.depth.empty() && name == s.depth.back().name) {
    return make_error(ErrorCode::kInvalidArgument,
                      s.directory.string() + ": depth timestamps " + io::format_exact(timestamp) +
                          " and " + io::format_exact(s.depth.back().timestamp) +
                          " are closer than 1 microsecond (same file name)");
  }
  IMUFUSION_RETURN_IF_ERROR(write_depth_png(s.directory / name, image));
  s.depth.push_back({timestamp, name});
  if (!s.as_you_go) return {};
  // info.txt carries depth_scale: on disk before the first frame that needs it.
  if (s.depth.size() == 1) {
    auto info = s.info_text();
    if (!info.ok()) return info.error();
    IMUFUSION_RETURN_IF_ERROR(io::write_text_atomically(s.directory / "info.txt", *info));
  }
  return s.depth_log.append(s.directory / "depth.txt", kDepthHeader, index_line(s.depth.back()));
}

Status SequenceWriter::add_color(double timestamp, const ColorImage& image) {
  State& s = *state_;
  IMUFUSION_RETURN_IF_ERROR(check_stamp(s.directory, "colour", timestamp, !s.color.empty(),
                                        s.color.empty() ? 0 : s.color.back().timestamp));
  if (s.width > 0 && (image.width != s.width || image.height != s.height)) {
    return make_error(ErrorCode::kInvalidArgument,
                      s.directory.string() + ": colour image at " + io::format_exact(timestamp) +
                          " is " + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + ", the depth images are " +
                          std::to_string(s.width) + "x" + std::to_string(s.height));
  }
  const std::string name = stamp_name("rgb", timestamp);
  if (!s.color.empty() && name == s.color.back().name) {
    return make_error(ErrorCode::kInvalidArgument,
                      s.directory.string() + ": colour timestamps closer than 1 microsecond");
  }
  IMUFUSION_RETURN_IF_ERROR(write_color_png(s.directory / name, image));
  s.color.push_back({timestamp, name});
  if (!s.as_you_go) return {};
  return s.color_log.append(s.directory / "rgb.txt", kColorHeader, index_line(s.color.back()));
}

Status SequenceWriter::add_imu(const ImuSample& sample) {
  State& s = *state_;
  IMUFUSION_RETURN_IF_ERROR(check_stamp(s.directory, "IMU", sample.timestamp, !s.imu.empty(),
                                        s.imu.empty() ? 0 : s.imu.back().timestamp));
  if (!sample.gyro.allFinite() || !sample.accel.allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, s.directory.string() + ": IMU sample at " +
                                                       io::format_exact(sample.timestamp) +
                                                       " is not finite");
  }
  s.imu.push_back(sample);
  if (!s.as_you_go || s.imu_forgotten) return {};
  return s.imu_log.append(s.directory / "imu.txt", kImuHeader, imu_line(sample));
}

void SequenceWriter::forget_imu() {
  state_->imu.clear();
  state_->imu_log.close();
  state_->imu_forgotten = true;
}

Status SequenceWriter::add_ground_truth(const StampedPose& pose) {
  State& s = *state_;
  IMUFUSION_RETURN_IF_ERROR(
      check_stamp(s.directory, "ground-truth", pose.timestamp, !s.ground_truth.empty(),
                  s.ground_truth.empty() ? 0 : s.ground_truth.back().timestamp));
  if (!pose.T_world_camera.matrix().allFinite()) {
    return make_error(ErrorCode::kInvalidArgument,
                      s.directory.string() + ": ground-truth pose at " +
                          io::format_exact(pose.timestamp) + " is not finite");
  }
  s.ground_truth.push_back(pose);
  return {};
}

Status SequenceWriter::set_intrinsics(const Intrinsics& k) {
  if (!(k.fx > 0 && k.fy > 0 && k.cx > 0 && k.cy > 0) ||
      !Eigen::Vector4d(k.fx, k.fy, k.cx, k.cy).allFinite()) {
    return make_error(ErrorCode::kInvalidArgument, state_->directory.string() + ": intrinsics " +
                                                       join_exact({k.fx, k.fy, k.cx, k.cy}) +
                                                       " must be positive and finite");
  }
  for (const double c : k.distortion) {
    if (!std::isfinite(c))
      return make_error(ErrorCode::kInvalidArgument,
                        state_->directory.string() + ": lens distortion " +
                            join_exact({k.distortion[0], k.distortion[1], k.distortion[2],
                                        k.distortion[3], k.distortion[4]}) +
                            " must be finite");
  }
  state_->intrinsics = k;
  if (!state_->as_you_go) return {};
  return io::write_text_atomically(state_->directory / "calibration.txt", calibration_text(k));
}

Status SequenceWriter::set_T_camera_imu(const Eigen::Isometry3d& T_camera_imu) {
  const Eigen::Matrix3d r = T_camera_imu.linear();
  if (!T_camera_imu.matrix().allFinite() ||
      !(r * r.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || r.determinant() < 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      state_->directory.string() + ": T_camera_imu is not a rigid transform");
  }
  state_->T_camera_imu = T_camera_imu;
  if (!state_->as_you_go) return {};
  return io::write_text_atomically(state_->directory / "imu_to_camera.txt",
                                   imu_to_camera_text(T_camera_imu));
}

Status SequenceWriter::set_info(const std::string& key, const std::string& value) {
  const bool bad_key =
      key.empty() || key.front() == '#' || key.find_first_of(" \t\r\n,") != std::string::npos;
  if (bad_key || value.empty() || value.find_first_of("\r\n") != std::string::npos) {
    return make_error(ErrorCode::kInvalidArgument,
                      state_->directory.string() + ": info key '" + key +
                          "' must be one word and its value one non-empty line");
  }
  bool replaced = false;
  for (auto& [existing, old_value] : state_->info) {
    if (existing == key) {
      old_value = value;
      replaced = true;
    }
  }
  if (!replaced) state_->info.emplace_back(key, value);
  // Before the first depth frame, info.txt waits for the image size and depth_scale.
  if (!state_->as_you_go || state_->depth.empty()) return {};
  auto info = state_->info_text();
  if (!info.ok()) return info.error();
  return io::write_text_atomically(state_->directory / "info.txt", *info);
}

Result<std::string> SequenceWriter::State::info_text() const {
  const fs::path& dir = directory;
  // depth_scale, width and height describe the images written; a caller's value must agree.
  const std::pair<const char*, double> derived[] = {
      {"depth_scale", depth_scale}, {"width", width}, {"height", height}};
  std::string text;
  for (const auto& [key, value] : derived) {
    text += std::string(key) + " " + io::format_exact(value) + "\n";
  }
  for (const auto& [key, value] : info) {
    bool is_derived = false;
    for (const auto& [derived_key, derived_value] : derived) {
      if (key != derived_key) continue;
      is_derived = true;
      auto parsed = io::parse_finite(value, dir / "info.txt", 0, key);
      if (!parsed.ok() || *parsed != derived_value) {
        return make_error(ErrorCode::kInvalidArgument, dir.string() + ": info " + key + " '" +
                                                           value +
                                                           "' disagrees with the depth images (" +
                                                           io::format_exact(derived_value) + ")");
      }
    }
    if (!is_derived) text += key + " " + value + "\n";
  }
  return text;
}

Status SequenceWriter::finish() {
  State& s = *state_;
  const fs::path& dir = s.directory;
  if (s.depth.empty()) {
    return make_error(ErrorCode::kInvalidArgument,
                      dir.string() + ": no depth frame was added; a sequence needs one");
  }
  auto info = s.info_text();
  if (!info.ok()) return info.error();
  // Each file is replaced whole: the appended ones, written as the frames came, too.
  s.depth_log.close();
  s.color_log.close();
  s.imu_log.close();

  std::string depth = kDepthHeader;
  for (const auto& line : s.depth) depth += index_line(line);
  IMUFUSION_RETURN_IF_ERROR(io::write_text_atomically(dir / "depth.txt", depth));
  if (!s.color.empty()) {
    std::string color = kColorHeader;
    for (const auto& line : s.color) color += index_line(line);
    IMUFUSION_RETURN_IF_ERROR(io::write_text_atomically(dir / "rgb.txt", color));
  }
  if (!s.imu.empty()) {
    std::string imu = kImuHeader;
    for (const ImuSample& m : s.imu) imu += imu_line(m);
    IMUFUSION_RETURN_IF_ERROR(io::write_text_atomically(dir / "imu.txt", imu));
  }
  if (!s.ground_truth.empty()) {
    // The TUM layout, with exact numbers so that a synthetic ground truth loses nothing.
    std::string gt = "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n";
    for (const StampedPose& pose : s.ground_truth) {
      const Eigen::Quaterniond q(pose.T_world_camera.linear());
      const Eigen::Vector3d& t = pose.T_world_camera.translation();
      gt += join_exact({pose.timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) + "\n";
    }
    IMUFUSION_RETURN_IF_ERROR(io::write_text_atomically(dir / "groundtruth.txt", gt));
  }
  if (s.intrinsics) {
    IMUFUSION_RETURN_IF_ERROR(
        io::write_text_atomically(dir / "calibration.txt", calibration_text(*s.intrinsics)));
  }
  if (s.T_camera_imu) {
    IMUFUSION_RETURN_IF_ERROR(
        io::write_text_atomically(dir / "imu_to_camera.txt", imu_to_camera_text(*s.T_camera_imu)));
  }
  return io::write_text_atomically(dir / "info.txt", *info);
}

}  // namespace imufusion
