#include "io/sequence_index.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "imufusion/trajectory.hpp"
#include "io/imu_gate.hpp"
#include "io/png_codec.hpp"
#include "io/text_table.hpp"

namespace imufusion::io {
namespace {

namespace fs = std::filesystem;

// |q| may be off 1 by rounding of the printed decimals; beyond this the line is corrupt.
constexpr double kQuaternionNormTolerance = 1e-3;

// The field of view of any depth camera lies between these (degrees); fx = width / (2 tan(fov/2)).
constexpr double kMinFieldOfViewDeg = 3.0, kMaxFieldOfViewDeg = 170.0;

double focal_for_fov(int pixels, double fov_deg) {
  return pixels / (2.0 * std::tan(0.5 * fov_deg * 3.14159265358979323846 / 180.0));
}

// An image an index lists must be a regular file (symbolic links followed): a FIFO would block
// its reader and a device never end. `where` prefixes the message.
Status check_image_file(const fs::path& image, const std::string& where) {
  std::error_code ec;
  const fs::file_status status = fs::status(image, ec);
  if (fs::is_regular_file(status)) return {};
  if (!fs::exists(status)) {
    return make_error(ErrorCode::kNotFound, where + image.string() + " does not exist");
  }
  return make_error(ErrorCode::kInvalidArgument,
                    where + image.string() +
                        (fs::is_directory(status)
                             ? " is not a regular file (a directory)"
                             : " is not a regular file (a FIFO, device or socket); images are "
                               "read from regular files only"));
}

class Loader {
 public:
  Loader(const fs::path& directory, const SequenceOptions& options)
      : dir_(directory), options_(options) {
    index_.info.directory = directory;
  }

  SequenceIndex run() {
    std::error_code ec;
    if (!fs::exists(dir_, ec)) {
      add(make_error(ErrorCode::kNotFound, dir_.string() + ": no such directory"));
      return std::move(index_);
    }
    if (!fs::is_directory(dir_, ec)) {
      add(make_error(ErrorCode::kInvalidArgument,
                     dir_.string() + ": not a directory (a sequence is a directory)"));
      return std::move(index_);
    }
    SequenceInfo& info = index_.info;
    load_info();
    load_image_index("depth.txt", /*required=*/true, info.depth);
    load_image_index("rgb.txt", /*required=*/false, info.color);
    load_intrinsics();
    load_imu_to_camera();
    load_imu();
    load_accelerometer();
    load_ground_truth();
    determine_image_size();
    check_intrinsics_plausible();
    if (info.intrinsics) {
      info.intrinsics->width = info.width;
      info.intrinsics->height = info.height;
    }
    std::vector<double> depth_stamps, color_stamps;
    for (const auto& entry : info.depth) depth_stamps.push_back(entry.timestamp);
    for (const auto& entry : info.color) color_stamps.push_back(entry.timestamp);
    info.color_of_depth =
        associate_streams(depth_stamps, color_stamps, options_.max_color_time_difference);
    return std::move(index_);
  }

 private:
  void add(Error error) { index_.problems.push_back(std::move(error)); }

  // Reads an optional (or required) file's lines; nullopt when absent or unreadable.
  std::optional<std::vector<TextLine>> lines_of(const std::string& name, bool required) {
    const fs::path path = dir_ / name;
    std::error_code ec;
    if (!fs::exists(path, ec)) {
      if (required) {
        add(make_error(ErrorCode::kNotFound,
                       path.string() + ": no such file (every sequence needs " + name + ")"));
      }
      return std::nullopt;
    }
    auto lines = read_text_table(path);
    if (!lines.ok()) {
      add(lines.error());
      return std::nullopt;
    }
    return std::move(*lines);
  }

  // Parses `count` finite numbers of `line`, naming them by `names`; false after a problem.
  bool parse_numbers(const TextLine& line, const fs::path& path,
                     const std::vector<const char*>& names, double* out) {
    const std::string layout = join(names);
    if (auto status = expect_fields(line, names.size(), path, layout); !status.ok()) {
      add(status.error());
      return false;
    }
    for (std::size_t i = 0; i < names.size(); ++i) {
      auto value = parse_finite(line.fields[i], path, line.number, names[i]);
      if (!value.ok()) {
        add(value.error());
        return false;
      }
      out[i] = *value;
    }
    return true;
  }

  static std::string join(const std::vector<const char*>& names) {
    std::string text;
    for (const char* name : names) {
      if (!text.empty()) text += ' ';
      text += name;
    }
    return text;
  }

  // Strictly increasing timestamps within one stream; false (and a problem) otherwise.
  bool check_increasing(double previous, bool has_previous, double timestamp, const TextLine& line,
                        const fs::path& path) {
    if (!has_previous || timestamp > previous) return true;
    add(make_error(ErrorCode::kParseError,
                   where(path, line.number) + "timestamp " + line.fields[0] +
                       (timestamp == previous
                            ? " is a duplicate of the previous line's"
                            : " is not after the previous line's " + format_exact(previous))));
    return false;
  }

  void load_info() {
    const fs::path path = dir_ / "info.txt";
    auto lines = lines_of("info.txt", false);
    if (!lines) return;
    SequenceInfo& info = index_.info;
    for (const TextLine& line : *lines) {
      const std::string& key = line.fields[0];
      const std::size_t key_end = line.text.find(key) + key.size();
      std::string value = line.text.substr(key_end);
      value.erase(0, value.find_first_not_of(" \t,"));
      value.erase(value.find_last_not_of(" \t") + 1);
      if (value.empty()) {
        add(make_error(ErrorCode::kParseError,
                       where(path, line.number) + "key '" + key + "' has no value"));
        continue;
      }
      if (info.info.count(key) != 0) {
        add(make_error(ErrorCode::kParseError,
                       where(path, line.number) + "key '" + key + "' is given twice"));
        continue;
      }
      info.info[key] = value;
      if (key == "depth_scale") {
        auto scale = parse_finite(value, path, line.number, "depth_scale");
        if (!scale.ok()) {
          add(scale.error());
        } else if (*scale <= 0) {
          add(make_error(ErrorCode::kParseError,
                         where(path, line.number) + "depth_scale " + value + " must be positive"));
        } else {
          info.depth_scale = *scale;
        }
      } else if (key == "width" || key == "height") {
        auto size = parse_integer(value, path, line.number, key, 1, 65535);
        if (!size.ok()) {
          add(size.error());
        } else {
          (key == "width" ? info_width_ : info_height_) = static_cast<int>(*size);
        }
      }
    }
  }

  void load_image_index(const std::string& name, bool required,
                        std::vector<ImageIndexEntry>& entries) {
    const fs::path path = dir_ / name;
    auto lines = lines_of(name, required);
    if (!lines) return;
    for (const TextLine& line : *lines) {
      double timestamp = 0;
      if (auto status = expect_fields(line, 2, path, "timestamp filename"); !status.ok()) {
        add(status.error());
        continue;
      }
      auto value = parse_finite(line.fields[0], path, line.number, "timestamp");
      if (!value.ok()) {
        add(value.error());
        continue;
      }
      timestamp = *value;
      if (!entries.empty() &&
          !check_increasing(entries.back().timestamp, true, timestamp, line, path)) {
        continue;
      }
      ImageIndexEntry entry{timestamp, line.fields[1], dir_ / line.fields[1]};
      if (auto status = check_image_file(entry.path, where(path, line.number)); !status.ok()) {
        add(status.error());
        continue;
      }
      entries.push_back(std::move(entry));
    }
    if (required && entries.empty() && lines->empty()) {
      add(make_error(ErrorCode::kParseError, path.string() + ": lists no frames"));
    }
  }

  void load_intrinsics() {
    SequenceInfo& info = index_.info;
    if (options_.intrinsics) {
      const Intrinsics& k = *options_.intrinsics;
      if (!(k.fx > 0 && k.fy > 0 && k.cx > 0 && k.cy > 0 && std::isfinite(k.fx) &&
            std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy))) {
        add(make_error(ErrorCode::kInvalidArgument,
                       "intrinsics passed by the caller must be positive and finite (fx " +
                           format_exact(k.fx) + " fy " + format_exact(k.fy) + " cx " +
                           format_exact(k.cx) + " cy " + format_exact(k.cy) + ")"));
      } else {
        info.intrinsics = k;
      }
    }
    const fs::path path = dir_ / "calibration.txt";
    auto lines = lines_of("calibration.txt", false);
    if (!lines) return;
    if (lines->size() != 1) {
      add(make_error(ErrorCode::kParseError,
                     path.string() + ": expected one line 'fx fy cx cy [k1 k2 p1 p2 k3]', found " +
                         std::to_string(lines->size())));
      return;
    }
    const TextLine& line = lines->front();
    // The lens distortion (OpenCV's order) may follow the pinhole's four numbers.
    double v[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    const bool with_distortion = line.fields.size() > 4;
    if (with_distortion) {
      if (!parse_numbers(line, path, {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}, v))
        return;
    } else if (!parse_numbers(line, path, {"fx", "fy", "cx", "cy"}, v)) {
      return;
    }
    static constexpr const char* kNames[4] = {"fx", "fy", "cx", "cy"};
    for (int i = 0; i < 4; ++i) {
      if (v[i] <= 0) {
        add(make_error(ErrorCode::kParseError, where(path, line.number) + kNames[i] + " " +
                                                   line.fields[i] + " must be positive"));
        return;
      }
    }
    if (!options_.intrinsics) {
      info.intrinsics = Intrinsics{v[0], v[1], v[2], v[3], 0, 0, {v[4], v[5], v[6], v[7], v[8]}};
      info.intrinsics_from_file = true;
    }
  }

  // Focal lengths must give a camera's field of view over the image, and the principal point
  // must lie on it: nonsense there makes fusion allocate without bound (1/fx).
  void check_intrinsics_plausible() {
    const SequenceInfo& info = index_.info;
    if (!info.intrinsics || info.width <= 0 || info.height <= 0) return;
    const Intrinsics& k = *info.intrinsics;
    const std::string source = info.intrinsics_from_file
                                   ? (dir_ / "calibration.txt").string() + ": "
                                   : std::string("intrinsics passed by the caller: ");
    const struct {
      const char* focal_name;
      double focal;
      const char* centre_name;
      double centre;
      int pixels;
      const char* extent;
    } axes[] = {{"fx", k.fx, "cx", k.cx, info.width, "width"},
                {"fy", k.fy, "cy", k.cy, info.height, "height"}};
    for (const auto& a : axes) {
      const double low = focal_for_fov(a.pixels, kMaxFieldOfViewDeg);
      const double high = focal_for_fov(a.pixels, kMinFieldOfViewDeg);
      if (!(a.focal >= low && a.focal <= high)) {
        add(make_error(ErrorCode::kInvalidArgument,
                       source + a.focal_name + " " + format_exact(a.focal) +
                           " is implausible for an image " + std::to_string(a.pixels) +
                           " pixels in " + a.extent + ": a camera's field of view of " +
                           format_exact(kMinFieldOfViewDeg) + " to " +
                           format_exact(kMaxFieldOfViewDeg) + " degrees needs " + a.focal_name +
                           " in [" + format_exact(std::round(low * 100) / 100) + ", " +
                           format_exact(std::round(high * 100) / 100) + "] pixels"));
      }
      if (!(a.centre >= 0 && a.centre <= a.pixels)) {
        add(make_error(ErrorCode::kInvalidArgument,
                       source + a.centre_name + " " + format_exact(a.centre) +
                           " lies outside the image (" + a.extent + " " + std::to_string(a.pixels) +
                           " pixels): the principal point must be " + "on the image, in [0, " +
                           std::to_string(a.pixels) + "]"));
      }
    }
  }

  void load_imu_to_camera() {
    const fs::path path = dir_ / "imu_to_camera.txt";
    auto lines = lines_of("imu_to_camera.txt", false);
    if (!lines) return;
    if (lines->size() != 1) {
      add(make_error(ErrorCode::kParseError,
                     path.string() + ": expected one line 'qx qy qz qw tx ty tz', found " +
                         std::to_string(lines->size())));
      return;
    }
    const TextLine& line = lines->front();
    double v[7];
    if (!parse_numbers(line, path, {"qx", "qy", "qz", "qw", "tx", "ty", "tz"}, v)) return;
    Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
    if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
      add(make_error(ErrorCode::kParseError, where(path, line.number) +
                                                 "quaternion (qx qy qz qw) has norm " +
                                                 format_exact(q.norm()) + ", expected 1"));
      return;
    }
    q.normalize();
    SequenceInfo& info = index_.info;
    info.T_camera_imu.linear() = q.toRotationMatrix();
    info.T_camera_imu.translation() = Eigen::Vector3d(v[4], v[5], v[6]);
    info.has_imu_to_camera = true;
  }

  void load_imu() {
    const fs::path path = dir_ / "imu.txt";
    auto lines = lines_of("imu.txt", false);
    if (!lines) return;
    SequenceInfo& info = index_.info;
    info.has_imu = true;
    info.imu.reserve(lines->size());
    ImuGate gate(options_.imu_limits);
    std::vector<ReceivedImuSample> released;
    for (const TextLine& line : *lines) {
      double v[7];
      if (!parse_numbers(line, path, {"timestamp", "wx", "wy", "wz", "ax", "ay", "az"}, v)) {
        continue;
      }
      const double latest = gate.latest();
      released.clear();
      const ReceivedImuSample sample{ImuSample{v[0], {v[1], v[2], v[3]}, {v[4], v[5], v[6]}}, 0};
      if (gate.push(sample, &released) == ImuVerdict::kOutOfOrder) {
        check_increasing(latest, true, v[0], line, path);
      }
      for (const ReceivedImuSample& accepted : released) info.imu.push_back(accepted.sample);
    }
    released.clear();
    gate.finish(&released);
    for (const ReceivedImuSample& accepted : released) info.imu.push_back(accepted.sample);
    info.imu_implausible = gate.implausible();
    info.imu_time_jumps = gate.time_jumps();
  }

  void load_accelerometer() {
    const fs::path path = dir_ / "accelerometer.txt";
    auto lines = lines_of("accelerometer.txt", false);
    if (!lines) return;
    auto& samples = index_.info.accelerometer;
    samples.reserve(lines->size());
    for (const TextLine& line : *lines) {
      double v[4];
      if (!parse_numbers(line, path, {"timestamp", "ax", "ay", "az"}, v)) continue;
      if (!check_increasing(samples.empty() ? 0 : samples.back().timestamp, !samples.empty(), v[0],
                            line, path)) {
        continue;
      }
      samples.push_back(AccelerometerSample{v[0], {v[1], v[2], v[3]}});
    }
  }

  void load_ground_truth() {
    const fs::path path = dir_ / "groundtruth.txt";
    std::error_code ec;
    if (!fs::exists(path, ec)) return;
    auto trajectory = read_trajectory(path);
    if (!trajectory.ok()) {
      add(trajectory.error());
      return;
    }
    index_.info.ground_truth = std::move(*trajectory);
    index_.info.has_ground_truth = true;
  }

  // The depth size: info.txt width/height, checked against the first depth PNG's header, or
  // that header alone.
  void determine_image_size() {
    SequenceInfo& info = index_.info;
    if ((info_width_ > 0) != (info_height_ > 0)) {
      add(make_error(ErrorCode::kParseError,
                     (dir_ / "info.txt").string() + ": gives only one of width and height"));
    }
    info.width = info_width_;
    info.height = info_height_;
    if (info.depth.empty()) return;
    const fs::path& first = info.depth.front().path;
    auto header = read_png_header(first);
    if (!header.ok()) {
      add(header.error());
      return;
    }
    if (info.width > 0 && info.height > 0 &&
        (header->width != info.width || header->height != info.height)) {
      add(make_error(ErrorCode::kParseError,
                     first.string() + ": image size " + std::to_string(header->width) + "x" +
                         std::to_string(header->height) + " differs from info.txt width " +
                         std::to_string(info.width) + " height " + std::to_string(info.height)));
      return;
    }
    info.width = header->width;
    info.height = header->height;
  }

  fs::path dir_;
  SequenceOptions options_;
  SequenceIndex index_;
  int info_width_ = 0, info_height_ = 0;
};

}  // namespace

SequenceIndex load_sequence_index(const std::filesystem::path& directory,
                                  const SequenceOptions& options) {
  return Loader(directory, options).run();
}

std::vector<int> associate_streams(const std::vector<double>& depth,
                                   const std::vector<double>& color, double max_difference) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
  std::size_t first = 0;
  for (std::size_t i = 0; i < depth.size(); ++i) {
    while (first < color.size() && color[first] <= depth[i] - max_difference) ++first;
    for (std::size_t j = first; j < color.size() && color[j] < depth[i] + max_difference; ++j) {
      candidates.emplace_back(std::abs(depth[i] - color[j]), i, j);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<int> color_of_depth(depth.size(), -1);
  std::vector<bool> color_used(color.size(), false);
  for (const auto& [difference, i, j] : candidates) {
    if (color_of_depth[i] >= 0 || color_used[j]) continue;
    color_of_depth[i] = static_cast<int>(j);
    color_used[j] = true;
  }
  return color_of_depth;
}

}  // namespace imufusion::io
