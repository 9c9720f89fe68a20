// imufusion-eval: compares an estimated trajectory with ground truth, both in the TUM format
// (`timestamp tx ty tz qx qy qz qw`), with the TUM RGB-D benchmark's ATE and RPE.
// Exit status: 0 success, 1 an input could not be read or evaluated, 2 a usage error.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_numbers.hpp"
#include "imufusion/eval.hpp"
#include "imufusion/trajectory.hpp"

namespace {

using imufusion::DeltaUnit;
using imufusion::ErrorStats;
using imufusion::RpeResult;
using imufusion::Trajectory;
using imufusion::TrajectoryMetrics;
using imufusion::tools::parse_number;

constexpr const char* kUsage =
    "usage: imufusion-eval GROUNDTRUTH ESTIMATE [--json] [--max-difference S] [--offset S]\n"
    "                      [--delta D [--delta-unit f|s]]\n"
    "\n"
    "Compares ESTIMATE with GROUNDTRUTH (TUM files: timestamp tx ty tz qx qy qz qw, metres,\n"
    "camera-to-world) as the TUM RGB-D benchmark does: poses are paired by nearest timestamp\n"
    "(greedy, one-to-one); ATE is measured after a rigid alignment without scale; RPE over one\n"
    "frame and over one second.\n"
    "\n"
    "  --json               print one JSON object (metres, degrees) instead of the summary\n"
    "  --max-difference S   largest timestamp difference for a pair, seconds (default 0.02)\n"
    "  --offset S           seconds added to every estimate timestamp (default 0)\n"
    "  --delta D            RPE step: replaces the per-frame step (unit f, a whole number) or\n"
    "                       the per-second step (unit s, seconds; the default unit)\n"
    "  --delta-unit f|s     unit of --delta\n"
    "  --help               show this text\n";

constexpr int kExitInputError = 1;
constexpr int kExitUsage = 2;

struct Arguments {
  std::string groundtruth;
  std::string estimate;
  bool json = false;
  imufusion::EvalOptions options;
};

int usage_error(const std::string& message) {
  std::cerr << "imufusion-eval: " << message << "\n" << kUsage;
  return kExitUsage;
}

// Returns the exit status on a usage error or --help, nothing when the arguments are complete.
std::optional<int> parse_arguments(int argc, char** argv, Arguments& args) {
  std::vector<std::string> positional;
  std::optional<double> delta;
  std::string delta_unit = "s";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto next_value = [&]() -> std::optional<std::string> {
      if (i + 1 >= argc) return std::nullopt;
      return std::string(argv[++i]);
    };
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (arg == "--json") {
      args.json = true;
    } else if (arg == "--max-difference" || arg == "--offset" || arg == "--delta") {
      const auto text = next_value();
      if (!text) return usage_error(arg + " needs a value");
      const auto value = parse_number(*text);
      if (!value) return usage_error(arg + ": '" + *text + "' is not a number");
      if (arg == "--max-difference") {
        if (*value <= 0) return usage_error("--max-difference must be positive, got " + *text);
        args.options.association.max_difference_s = *value;
      } else if (arg == "--offset") {
        args.options.association.time_offset_s = *value;
      } else {
        if (*value <= 0) return usage_error("--delta must be positive, got " + *text);
        delta = *value;
      }
    } else if (arg == "--delta-unit") {
      const auto text = next_value();
      if (!text) return usage_error("--delta-unit needs a value (f or s)");
      if (*text != "f" && *text != "s") {
        return usage_error("--delta-unit must be f (frames) or s (seconds), got '" + *text + "'");
      }
      delta_unit = *text;
    } else if (arg.size() > 1 && arg[0] == '-') {
      return usage_error("unknown option " + arg);
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 2) {
    return usage_error("expected GROUNDTRUTH and ESTIMATE files, got " +
                       std::to_string(positional.size()) + " file argument(s)");
  }
  args.groundtruth = positional[0];
  args.estimate = positional[1];
  if (delta) {
    if (delta_unit == "f") {
      if (*delta != std::floor(*delta)) {
        return usage_error("--delta in frames must be a whole number, got " +
                           std::to_string(*delta));
      }
      args.options.rpe_frame.delta = *delta;
    } else {
      args.options.rpe_second.delta = *delta;
    }
  }
  return std::nullopt;
}

std::optional<Trajectory> load(const std::string& path, const char* role) {
  auto trajectory = imufusion::read_trajectory(path);
  if (!trajectory.ok()) {
    const std::string& message = trajectory.error().message;
    // The reader names the file in its messages; name it here when it does not.
    const std::string prefix = message.find(path) == std::string::npos ? path + ": " : "";
    std::cerr << "imufusion-eval: " << role << " " << prefix << trajectory.error().describe()
              << "\n";
    return std::nullopt;
  }
  if (trajectory->empty()) {
    std::cerr << "imufusion-eval: " << role << " " << path
              << ": no poses (only comments or blank lines)\n";
    return std::nullopt;
  }
  return std::move(trajectory).value();
}

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

// "frame", "5 frames", "s", "2 s": the step an RPE figure is measured over.
std::string step_name(const imufusion::RpeOptions& options) {
  if (options.unit == DeltaUnit::kFrames) {
    return options.delta == 1.0 ? "frame" : format("%.0f frames", options.delta);
  }
  return options.delta == 1.0 ? "s" : format("%g s", options.delta);
}

void print_stats_line(const char* label, const ErrorStats& stats, double scale, const char* pattern,
                      const std::string& unit) {
  std::cout << "  " << label << "  rmse " << format(pattern, stats.rmse * scale) << "  mean "
            << format(pattern, stats.mean * scale) << "  median "
            << format(pattern, stats.median * scale) << "  max "
            << format(pattern, stats.max * scale) << " " << unit << "\n";
}

void print_rpe(const std::string& title, const RpeResult& rpe) {
  const std::string step = step_name(rpe.options);
  if (rpe.pairs.empty()) {
    std::cout << title << ": no pose pairs " << format("%g", rpe.options.delta)
              << (rpe.options.unit == DeltaUnit::kFrames ? " frame(s)" : " s")
              << " apart (trajectory too short";
    if (rpe.options.unit == DeltaUnit::kSeconds) {
      std::cout << ", or no partner within " << format("%g", rpe.options.time_tolerance_s) << " s";
    }
    std::cout << ")\n";
    return;
  }
  std::cout << title << " (" << rpe.pairs.size() << " pairs):\n";
  print_stats_line("trans", rpe.trans_m, 1.0, "%.5f", "m/" + step);
  print_stats_line("rot  ", rpe.rot_deg, 1.0, "%.4f", "deg/" + step);
}

void print_summary(const Arguments& args, const TrajectoryMetrics& m) {
  std::cout << "ground truth  " << args.groundtruth << ": " << m.gt_poses << " poses, "
            << format("%.6f", m.gt_span.begin) << " .. " << format("%.6f", m.gt_span.end) << " s\n";
  std::cout << "estimate      " << args.estimate << ": " << m.est_poses << " poses, "
            << format("%.6f", m.est_span.begin) << " .. " << format("%.6f", m.est_span.end)
            << " s\n";
  const std::size_t matched = m.ate.matches.size();
  std::cout << "matched       " << matched << " of " << m.gt_poses << " ground-truth and "
            << matched << " of " << m.est_poses << " estimate poses (max difference "
            << format("%g", m.association.max_difference_s) << " s";
  if (m.association.time_offset_s != 0.0) {
    std::cout << ", estimate offset " << format("%g", m.association.time_offset_s) << " s";
  }
  std::cout << ")\n";
  std::cout << "ATE after rigid alignment (no scale), " << matched << " poses:\n";
  print_stats_line("trans", m.ate.stats, 100.0, "%.3f", "cm");
  const std::string frame_title = "RPE per " + step_name(m.rpe_frame.options);
  const std::string second_title =
      "RPE per " +
      (m.rpe_second.options.delta == 1.0 ? std::string("second") : step_name(m.rpe_second.options));
  print_rpe(frame_title, m.rpe_frame);
  print_rpe(second_title, m.rpe_second);
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  if (const auto exit_status = parse_arguments(argc, argv, args)) return *exit_status;

  const auto groundtruth = load(args.groundtruth, "ground truth");
  if (!groundtruth) return kExitInputError;
  const auto estimate = load(args.estimate, "estimate");
  if (!estimate) return kExitInputError;

  const auto metrics = imufusion::evaluate(*groundtruth, *estimate, args.options);
  if (!metrics.ok()) {
    std::cerr << "imufusion-eval: cannot evaluate " << args.estimate << " against "
              << args.groundtruth << ": " << metrics.error().describe() << "\n";
    return kExitInputError;
  }
  if (args.json) {
    std::cout << imufusion::to_json(*metrics) << "\n";
  } else {
    print_summary(args, *metrics);
  }
  return 0;
}
