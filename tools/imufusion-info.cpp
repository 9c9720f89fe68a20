// imufusion-info: checks a recorded sequence (FORMAT.md) and prints what a person needs before
// scanning it: frames, rates and gaps, image size, intrinsics, colour, IMU, T_camera_imu, ground
// truth coverage, and every problem found (every depth and colour image is decoded).
// Exit status: 0 the sequence can be scanned, 1 it cannot (problems listed on stderr), 2 usage.

#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/sequence_check.hpp"
#include "json_text.hpp"

namespace {

using imufusion::io::SequenceCheck;
using imufusion::io::StreamTiming;

constexpr const char* kUsage =
    "usage: imufusion-info SEQUENCE [--json]\n"
    "\n"
    "Checks the recorded sequence in directory SEQUENCE (depth.txt, depth PNGs, rgb.txt,\n"
    "calibration.txt, imu.txt, imu_to_camera.txt, groundtruth.txt, info.txt) and prints a\n"
    "summary. Every depth and colour image is decoded. Problems go to stderr, naming the file.\n"
    "\n"
    "  --json   print one JSON object instead of the summary\n"
    "  --help   show this text\n"
    "\n"
    "Exit status: 0 scannable, 1 not scannable (missing or corrupt depth, bad index files,\n"
    "no intrinsics), 2 usage error.\n";

constexpr int kExitNotScannable = 1;
constexpr int kExitUsage = 2;
// The summary lists this many gaps per stream; the count says how many there are in all.
constexpr std::size_t kGapsShown = 5;

std::string format(const char* pattern, double value) {
  char buffer[128];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

void print_gaps(const StreamTiming& timing, const char* what) {
  if (timing.gaps.empty()) {
    std::cout << "  gaps: none (no interval over 1.5x the median)\n";
    return;
  }
  std::cout << "  gaps: " << timing.gaps.size() << " " << what << " intervals over 1.5x the median"
            << (timing.gaps.size() > kGapsShown ? ", first " + std::to_string(kGapsShown) : "")
            << ":\n";
  for (std::size_t i = 0; i < timing.gaps.size() && i < kGapsShown; ++i) {
    const auto& gap = timing.gaps[i];
    std::cout << "    after " << format("%.6f", gap.after) << " (+"
              << format("%.3f", gap.after - timing.first) << " s): " << format("%.3f", gap.length)
              << " s\n";
  }
}

void print_summary(const SequenceCheck& check) {
  const auto& info = check.index.info;
  const std::size_t frames = info.depth.size();
  std::cout << "sequence: " << info.directory.string() << "\n";
  std::cout << "depth: " << frames << " frames";
  if (check.depth.count >= 2) {
    std::cout << ", " << format("%.3f", check.depth.last - check.depth.first) << " s, "
              << format("%.2f", check.depth.rate_hz) << " Hz (median interval "
              << format("%.4f", check.depth.median_interval) << " s)";
  }
  std::cout << "\n";
  if (check.depth.count >= 2) print_gaps(check.depth, "depth");
  std::cout << "  decoded: " << check.depth_decoded << " of " << frames << " PNGs, "
            << format("%.1f", 100.0 * check.mean_valid_depth_fraction)
            << "% valid pixels on average\n";
  std::cout << "image size: " << info.width << "x" << info.height << ", depth_scale "
            << format("%g", info.depth_scale) << " per metre\n";
  if (info.intrinsics) {
    const auto& k = *info.intrinsics;
    std::cout << "intrinsics: fx " << format("%g", k.fx) << " fy " << format("%g", k.fy) << " cx "
              << format("%g", k.cx) << " cy " << format("%g", k.cy) << " ("
              << (info.intrinsics_from_file ? "calibration.txt" : "caller") << ")\n";
    if (k.distorted()) {
      const auto& d = k.distortion;
      std::cout << "lens distortion: k1 " << format("%g", d[0]) << " k2 " << format("%g", d[1])
                << " p1 " << format("%g", d[2]) << " p2 " << format("%g", d[3]) << " k3 "
                << format("%g", d[4]) << " (frames resampled to the pinhole)\n";
    }
  } else {
    std::cout << "intrinsics: missing: pass intrinsics (no calibration.txt)\n";
  }
  if (info.color.empty()) {
    std::cout << "colour: none (no rgb.txt)\n";
  } else {
    std::cout << "colour: " << info.color.size() << " frames (" << check.color_decoded
              << " decoded), " << check.color_matched << " of " << frames
              << " depth frames matched within 20 ms\n";
  }
  if (!info.has_imu) {
    std::cout << "imu: none: the scan will run without inertial aid\n";
  } else {
    std::cout << "imu: " << check.imu.count << " samples";
    if (check.imu.count >= 2) {
      std::cout << ", " << format("%.1f", check.imu.rate_hz) << " Hz, "
                << format("%.6f", check.imu.first) << " .. " << format("%.6f", check.imu.last)
                << (check.imu_spans_frames ? " (spans all depth frames)"
                                           : " (does NOT span all depth frames)");
    }
    std::cout << "\n";
    if (check.imu.count >= 2) print_gaps(check.imu, "IMU");
    std::cout << "  depth frames without an IMU sample since the previous frame: "
              << check.frames_without_imu << "; inside its span: " << check.frames_within_imu
              << " of " << frames << "\n";
    std::cout << "  left out: " << info.imu_implausible << " samples beyond a real IMU's range, "
              << info.imu_time_jumps << " jumps in time\n";
  }
  const Eigen::Quaterniond q(info.T_camera_imu.linear());
  const Eigen::Vector3d t = info.T_camera_imu.translation();
  std::cout << "T_camera_imu: q (x y z w) " << format("%.6f", q.x()) << " " << format("%.6f", q.y())
            << " " << format("%.6f", q.z()) << " " << format("%.6f", q.w()) << ", t "
            << format("%.4f", t.x()) << " " << format("%.4f", t.y()) << " " << format("%.4f", t.z())
            << " m" << (info.has_imu_to_camera ? "" : " (identity: no imu_to_camera.txt)") << "\n";
  if (!info.has_ground_truth) {
    std::cout << "ground truth: none\n";
  } else if (!info.ground_truth.empty()) {
    std::cout << "ground truth: " << info.ground_truth.size() << " poses, "
              << format("%.6f", info.ground_truth.front().timestamp) << " .. "
              << format("%.6f", info.ground_truth.back().timestamp) << "; first/last depth frame "
              << (check.ground_truth_spans_frames ? "inside" : "NOT inside") << " its span; "
              << check.frames_with_ground_truth << " of " << frames << " frames ("
              << format("%.1f", frames == 0
                                    ? 0.0
                                    : 100.0 * static_cast<double>(check.frames_with_ground_truth) /
                                          static_cast<double>(frames))
              << "%) have a pose within 20 ms\n";
  }
  for (const std::string& warning : check.warnings) std::cout << "warning: " << warning << "\n";
  std::cout << (check.scannable
                    ? "verdict: scannable\n"
                    : "verdict: NOT scannable: " + std::to_string(check.index.problems.size()) +
                          " problems (listed on stderr)\n");
}

nlohmann::json timing_json(const StreamTiming& timing) {
  nlohmann::json gaps = nlohmann::json::array();
  for (const auto& gap : timing.gaps)
    gaps.push_back({{"after", gap.after}, {"length", gap.length}});
  return {{"count", timing.count},     {"first", timing.first},
          {"last", timing.last},       {"median_interval", timing.median_interval},
          {"rate_hz", timing.rate_hz}, {"gaps", gaps}};
}

nlohmann::json summary_json(const SequenceCheck& check) {
  const auto& info = check.index.info;
  nlohmann::json out;
  out["sequence"] = info.directory.string();
  out["scannable"] = check.scannable;
  out["depth"] = timing_json(check.depth);
  out["depth"]["decoded"] = check.depth_decoded;
  out["depth"]["mean_valid_fraction"] = check.mean_valid_depth_fraction;
  out["width"] = info.width;
  out["height"] = info.height;
  out["depth_scale"] = info.depth_scale;
  if (info.intrinsics) {
    const auto& k = *info.intrinsics;
    out["intrinsics"] = {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}};
  } else {
    out["intrinsics"] = nullptr;
  }
  out["color"] = {{"count", info.color.size()},
                  {"decoded", check.color_decoded},
                  {"matched_depth_frames", check.color_matched}};
  if (info.has_imu) {
    out["imu"] = timing_json(check.imu);
    out["imu"]["spans_depth_frames"] = check.imu_spans_frames;
    out["imu"]["depth_frames_without_samples"] = check.frames_without_imu;
    out["imu"]["depth_frames_within_span"] = check.frames_within_imu;
    out["imu"]["implausible_samples"] = info.imu_implausible;
    out["imu"]["time_jumps"] = info.imu_time_jumps;
  } else {
    out["imu"] = nullptr;
  }
  const Eigen::Quaterniond q(info.T_camera_imu.linear());
  const Eigen::Vector3d t = info.T_camera_imu.translation();
  out["T_camera_imu"] = {{"q_xyzw", {q.x(), q.y(), q.z(), q.w()}},
                         {"t", {t.x(), t.y(), t.z()}},
                         {"from_file", info.has_imu_to_camera}};
  if (info.has_ground_truth) {
    out["ground_truth"] = {{"poses", info.ground_truth.size()},
                           {"spans_depth_frames", check.ground_truth_spans_frames},
                           {"frames_within_20ms", check.frames_with_ground_truth}};
  } else {
    out["ground_truth"] = nullptr;
  }
  out["warnings"] = check.warnings;
  nlohmann::json problems = nlohmann::json::array();
  for (const auto& problem : check.index.problems) problems.push_back(problem.describe());
  out["problems"] = problems;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> positional;
  bool json = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    }
    if (arg == "--json") {
      json = true;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "imufusion-info: unknown option " << arg << "\n" << kUsage;
      return kExitUsage;
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 1) {
    std::cerr << "imufusion-info: expected one SEQUENCE directory\n" << kUsage;
    return kExitUsage;
  }

  // A progress count only for a person watching a terminal, never into a log or a pipe.
  const bool show_progress = isatty(STDERR_FILENO) != 0;
  const SequenceCheck check =
      imufusion::io::check_sequence(positional.front(), [&](std::size_t done, std::size_t total) {
        if (show_progress && (done % 25 == 0 || done == total)) {
          std::cerr << "\rdecoding images " << done << "/" << total << (done == total ? "\n" : "")
                    << std::flush;
        }
      });

  if (json) {
    std::cout << imufusion::tools::json_text(summary_json(check)) << "\n";
  } else {
    print_summary(check);
  }
  for (const auto& problem : check.index.problems) {
    std::cerr << "imufusion-info: " << problem.describe() << "\n";
  }
  return check.scannable ? 0 : kExitNotScannable;
}
