#include "io/sequence_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "imufusion/image_io.hpp"
#include "imufusion/preprocess.hpp"

namespace imufusion::io {
namespace {

std::string seconds(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.3f s", value);
  return buffer;
}

std::string percent(std::size_t part, std::size_t whole) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.1f%%",
                whole == 0 ? 0.0 : 100.0 * static_cast<double>(part) / static_cast<double>(whole));
  return buffer;
}

template <typename Image>
std::string size_text(const Image& image) {
  return std::to_string(image.width) + "x" + std::to_string(image.height);
}

// Decodes every image: the only way to find a truncated or corrupt file before a scan does.
// Colour images count as problems too, since SequenceReader::next() fails on them.
void check_images(SequenceCheck& check,
                  const std::function<void(std::size_t, std::size_t)>& progress) {
  const SequenceInfo& info = check.index.info;
  const std::size_t total = info.depth.size() + info.color.size();
  double valid_sum = 0;
  for (std::size_t i = 0; i < info.depth.size(); ++i) {
    const ImageIndexEntry& entry = info.depth[i];
    auto image = read_depth_png(entry.path, info.depth_scale);
    if (!image.ok()) {
      check.index.problems.push_back(image.error());
    } else if (info.width > 0 && (image->width != info.width || image->height != info.height)) {
      check.index.problems.push_back(make_error(
          ErrorCode::kParseError, entry.path.string() + ": image size " + size_text(*image) +
                                      " differs from the sequence's " + std::to_string(info.width) +
                                      "x" + std::to_string(info.height)));
    } else {
      const auto valid = std::count_if(image->data.begin(), image->data.end(),
                                       [](std::uint16_t d) { return d > 0; });
      valid_sum += static_cast<double>(valid) / static_cast<double>(image->data.size());
      ++check.depth_decoded;
    }
    if (progress) progress(i + 1, total);
  }
  if (check.depth_decoded > 0) {
    check.mean_valid_depth_fraction = valid_sum / static_cast<double>(check.depth_decoded);
  }
  for (std::size_t j = 0; j < info.color.size(); ++j) {
    const ImageIndexEntry& entry = info.color[j];
    auto image = read_color_image(entry.path);
    if (!image.ok()) {
      check.index.problems.push_back(image.error());
    } else if (info.width > 0 && (image->width != info.width || image->height != info.height)) {
      check.index.problems.push_back(make_error(
          ErrorCode::kParseError, entry.path.string() + ": colour size " + size_text(*image) +
                                      " differs from the depth size " + std::to_string(info.width) +
                                      "x" + std::to_string(info.height)));
    } else {
      ++check.color_decoded;
    }
    if (progress) progress(info.depth.size() + j + 1, total);
  }
}

void check_imu(SequenceCheck& check, const std::vector<double>& depth_stamps) {
  const SequenceInfo& info = check.index.info;
  std::vector<double> stamps;
  for (const ImuSample& sample : info.imu) stamps.push_back(sample.timestamp);
  check.imu = stream_timing(stamps);
  if (!info.has_imu) {
    check.warnings.push_back("no IMU (imu.txt absent): the scan will run without inertial aid");
    return;
  }
  if (info.imu_implausible > 0 || info.imu_time_jumps > 0) {
    check.warnings.push_back("imu.txt: " + std::to_string(info.imu_implausible) +
                             " samples beyond a real IMU's range (or not finite) and " +
                             std::to_string(info.imu_time_jumps) + " jumps in time are left out");
  }
  if (depth_stamps.empty()) return;
  check.frames_within_imu = frames_within_imu(info.imu, depth_stamps);
  if (check.frames_within_imu == 0) {
    check.warnings.push_back(
        "imu.txt covers none of the depth frames" +
        (stamps.empty()
             ? std::string(" (no usable sample)")
             : " (" + seconds(stamps.front()) + " .. " + seconds(stamps.back()) + " against " +
                   seconds(depth_stamps.front()) + " .. " + seconds(depth_stamps.back()) + ")") +
        ": the scan will run without the IMU");
    return;
  }
  check.imu_spans_frames =
      stamps.front() <= depth_stamps.front() && stamps.back() >= depth_stamps.back();
  for (std::size_t i = 1; i < depth_stamps.size(); ++i) {
    const auto next = std::upper_bound(stamps.begin(), stamps.end(), depth_stamps[i - 1]);
    if (next == stamps.end() || *next > depth_stamps[i]) ++check.frames_without_imu;
  }
  if (!check.imu_spans_frames) {
    check.warnings.push_back("imu.txt covers " + seconds(stamps.front()) + " .. " +
                             seconds(stamps.back()) + ", not all depth frames (" +
                             seconds(depth_stamps.front()) + " .. " + seconds(depth_stamps.back()) +
                             ")");
  }
  if (check.frames_without_imu > 0) {
    check.warnings.push_back(std::to_string(check.frames_without_imu) +
                             " depth frames have no IMU sample since the previous frame");
  }
  if (!check.imu.gaps.empty()) {
    check.warnings.push_back("imu.txt has " + std::to_string(check.imu.gaps.size()) +
                             " gaps (intervals over 1.5x its median)");
  }
}

void check_ground_truth(SequenceCheck& check, const std::vector<double>& depth_stamps) {
  const SequenceInfo& info = check.index.info;
  if (!info.has_ground_truth || info.ground_truth.empty() || depth_stamps.empty()) return;
  std::vector<double> stamps;
  for (const StampedPose& pose : info.ground_truth) stamps.push_back(pose.timestamp);
  check.ground_truth_spans_frames =
      stamps.front() <= depth_stamps.front() && stamps.back() >= depth_stamps.back();
  for (double t : depth_stamps) {
    const auto after = std::lower_bound(stamps.begin(), stamps.end(), t);
    double nearest = std::numeric_limits<double>::infinity();
    if (after != stamps.end()) nearest = *after - t;
    if (after != stamps.begin()) nearest = std::min(nearest, t - *(after - 1));
    if (nearest <= kGroundTruthMaxDifference) ++check.frames_with_ground_truth;
  }
  if (check.frames_with_ground_truth < depth_stamps.size()) {
    check.warnings.push_back(
        "ground truth covers " + percent(check.frames_with_ground_truth, depth_stamps.size()) +
        " of the depth frames (a pose within 20 ms); the others are left out of ATE");
  }
}

// The scan's depth pyramid (PreprocessConfig::levels, the tools' setting) halves the image
// levels - 1 times and needs 2^levels pixels on each side: a smaller image cannot be scanned.
void check_size_for_pyramid(SequenceCheck& check) {
  const SequenceInfo& info = check.index.info;
  const int levels = PreprocessConfig{}.levels;
  const int minimum = 1 << levels;
  if (info.depth.empty() || info.width <= 0 || info.height <= 0 ||
      (info.width >= minimum && info.height >= minimum)) {
    return;
  }
  check.index.problems.push_back(make_error(
      ErrorCode::kUnsupported,
      info.depth.front().path.string() + ": image size " + std::to_string(info.width) + "x" +
          std::to_string(info.height) + " is too small to scan: the depth pyramid's " +
          std::to_string(levels) + " levels need " + std::to_string(minimum) + "x" +
          std::to_string(minimum) + " pixels or more"));
}

}  // namespace

StreamTiming stream_timing(const std::vector<double>& stamps) {
  StreamTiming timing;
  timing.count = stamps.size();
  if (stamps.empty()) return timing;
  timing.first = stamps.front();
  timing.last = stamps.back();
  if (stamps.size() < 2) return timing;
  std::vector<double> intervals;
  for (std::size_t i = 1; i < stamps.size(); ++i) intervals.push_back(stamps[i] - stamps[i - 1]);
  std::vector<double> sorted = intervals;
  const std::size_t mid = sorted.size() / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid), sorted.end());
  timing.median_interval = sorted[mid];
  if (sorted.size() % 2 == 0) {
    const double lower =
        *std::max_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid));
    timing.median_interval = 0.5 * (timing.median_interval + lower);
  }
  if (timing.median_interval > 0) timing.rate_hz = 1.0 / timing.median_interval;
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    if (intervals[i] > kGapFactor * timing.median_interval) {
      timing.gaps.push_back({stamps[i], intervals[i]});
    }
  }
  return timing;
}

std::size_t frames_within_imu(const std::vector<ImuSample>& imu,
                              const std::vector<double>& depth_stamps) {
  if (imu.empty()) return 0;
  const double first = imu.front().timestamp, last = imu.back().timestamp;
  return static_cast<std::size_t>(std::count_if(depth_stamps.begin(), depth_stamps.end(),
                                                [&](double t) { return t >= first && t <= last; }));
}

SequenceCheck check_sequence(const std::filesystem::path& directory,
                             const std::function<void(std::size_t, std::size_t)>& progress) {
  SequenceCheck check;
  check.index = load_sequence_index(directory, SequenceOptions{});
  const SequenceInfo& info = check.index.info;
  std::vector<double> depth_stamps;
  for (const ImageIndexEntry& entry : info.depth) depth_stamps.push_back(entry.timestamp);
  check.depth = stream_timing(depth_stamps);
  check_images(check, progress);
  check_size_for_pyramid(check);
  if (!check.depth.gaps.empty()) {
    check.warnings.push_back("depth.txt has " + std::to_string(check.depth.gaps.size()) +
                             " gaps (dropped frames?): tracking must bridge them");
  }
  check.color_matched = static_cast<std::size_t>(std::count_if(
      info.color_of_depth.begin(), info.color_of_depth.end(), [](int j) { return j >= 0; }));
  if (!info.color.empty() && check.color_matched < info.depth.size()) {
    check.warnings.push_back(std::to_string(info.depth.size() - check.color_matched) +
                             " depth frames have no colour frame within 20 ms");
  }
  check_imu(check, depth_stamps);
  check_ground_truth(check, depth_stamps);
  std::error_code ec;
  if (!info.intrinsics && std::filesystem::is_directory(directory, ec)) {
    check.index.problems.push_back(make_error(
        ErrorCode::kNotFound, (directory / "calibration.txt").string() +
                                  ": missing: pass intrinsics (fx fy cx cy) to the scan"));
  }
  check.scannable = check.index.problems.empty();
  return check;
}

}  // namespace imufusion::io
