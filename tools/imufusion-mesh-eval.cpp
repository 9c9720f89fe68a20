// imufusion-mesh-eval: accuracy and completeness of a reconstructed mesh against the analytic
// scene of a synthetic sequence (imufusion-synth), counting only surfaces the camera saw.
// Exit status: 0 success, 1 an input could not be read or evaluated, 2 a usage error.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli_numbers.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/mesh_eval.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"
#include "json_text.hpp"

namespace {

using imufusion::tools::parse_integer;
using imufusion::tools::parse_number;

constexpr const char* kUsage =
    "usage: imufusion-mesh-eval MESH.ply|MESH.glb --scene room|wall|fast --seed N\n"
    "                           --groundtruth FILE [--intrinsics FX FY CX CY] [--size WxH]\n"
    "                           [--threshold M] [--spacing M] [--frame-step N] [--pixel-step N]\n"
    "                           [--json]\n"
    "       imufusion-mesh-eval MESH.ply|MESH.glb --sequence DIR [options as above]\n"
    "\n"
    "Compares MESH (world frame, metres) with the synthetic scene it was scanned from.\n"
    "Reference points: the true surface seen by exact ray casts from the GROUNDTRUTH poses (TUM\n"
    "format) through every pixel-step-th pixel, within 0.4-4.5 m and 78 deg incidence, one per\n"
    "cm^3. Accuracy: distance from area-uniform mesh samples (one per 5 mm x 5 mm) to the true\n"
    "surface (at most 4 million samples). Completeness: fraction of reference points within the\n"
    "threshold of the mesh.\n"
    "\n"
    "  --sequence DIR         an imufusion-synth sequence: scene and seed from its info.txt,\n"
    "                         poses from groundtruth.txt, camera from calibration.txt and the\n"
    "                         image size (the options below override each)\n"
    "  --scene, --seed        the scene of imufusion-synth (the seed changes only colours)\n"
    "  --groundtruth FILE     the sequence's groundtruth.txt\n"
    "  --intrinsics FX FY CX CY  pinhole intrinsics, pixels (default: the synthetic camera)\n"
    "  --size WxH             image size (default 640x480)\n"
    "  --threshold M          completeness distance, metres (default 0.02)\n"
    "  --spacing M            one accuracy sample per M x M of mesh area, metres (default 0.005)\n"
    "  --frame-step N         use every N-th pose (default 1)\n"
    "  --pixel-step N         cast every N-th pixel on both axes (default 8)\n"
    "  --json                 print one JSON object instead of the summary\n"
    "  --help                 show this text\n";

constexpr int kExitInputError = 1;
constexpr int kExitUsage = 2;

struct Arguments {
  std::string mesh, groundtruth, sequence;
  std::optional<imufusion::synth::SceneKind> scene;
  std::optional<std::uint64_t> seed;
  std::optional<std::array<double, 4>> intrinsics;
  std::optional<std::pair<int, int>> size;  // width, height
  bool json = false;
  imufusion::MeshEvalOptions eval;
  imufusion::SurfaceSampleOptions samples;
};

int usage_error(const std::string& message) {
  std::cerr << "imufusion-mesh-eval: " << message << "\n" << kUsage;
  return kExitUsage;
}

// --intrinsics FX FY CX CY (pixels): the exit status on a usage error, nothing when read.
std::optional<int> parse_intrinsics(const std::array<std::optional<std::string>, 4>& texts,
                                    Arguments& args) {
  std::array<double, 4> values{};
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto number = texts[i] ? parse_number(*texts[i]) : std::nullopt;
    if (!number) return usage_error("--intrinsics needs four numbers: FX FY CX CY");
    values[i] = *number;
  }
  if (values[0] <= 0 || values[1] <= 0) return usage_error("--intrinsics: FX and FY must be > 0");
  args.intrinsics = values;
  return std::nullopt;
}

// --size WxH: the exit status on a usage error, nothing when read.
std::optional<int> parse_size(const std::optional<std::string>& text, Arguments& args) {
  const auto x = text ? text->find('x') : std::string::npos;
  const auto w = x != std::string::npos ? parse_integer(text->substr(0, x)) : std::nullopt;
  const auto h = x != std::string::npos ? parse_integer(text->substr(x + 1)) : std::nullopt;
  if (!w || !h || *w <= 0 || *h <= 0 || *w > 100000 || *h > 100000) {
    return usage_error("--size needs WxH with positive whole numbers, e.g. 640x480");
  }
  args.size = {static_cast<int>(*w), static_cast<int>(*h)};
  return std::nullopt;
}

// Returns the exit status on a usage error or --help, nothing when the arguments are complete.
std::optional<int> parse_arguments(int argc, char** argv, Arguments& args) {
  std::vector<std::string> positional;
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
    } else if (arg == "--scene") {
      const auto text = next_value();
      if (!text) return usage_error("--scene needs a value (room, wall or fast)");
      args.scene = imufusion::synth::parse_scene_kind(*text);
      if (!args.scene)
        return usage_error("--scene must be room, wall or fast, got '" + *text + "'");
    } else if (arg == "--seed") {
      const auto text = next_value();
      const auto value = text ? parse_integer(*text) : std::nullopt;
      if (!value || *value < 0) return usage_error("--seed needs a non-negative whole number");
      args.seed = static_cast<std::uint64_t>(*value);
    } else if (arg == "--sequence") {
      const auto text = next_value();
      if (!text) return usage_error("--sequence needs a directory");
      args.sequence = *text;
    } else if (arg == "--groundtruth") {
      const auto text = next_value();
      if (!text) return usage_error("--groundtruth needs a file");
      args.groundtruth = *text;
    } else if (arg == "--intrinsics") {
      std::array<std::optional<std::string>, 4> texts;
      for (auto& text : texts) text = next_value();
      if (const auto status = parse_intrinsics(texts, args)) return status;
    } else if (arg == "--size") {
      if (const auto status = parse_size(next_value(), args)) return status;
    } else if (arg == "--threshold" || arg == "--spacing") {
      const auto text = next_value();
      const auto value = text ? parse_number(*text) : std::nullopt;
      if (!value || *value <= 0) return usage_error(arg + " needs a positive distance (metres)");
      (arg == "--threshold" ? args.eval.completeness_threshold : args.eval.sample_spacing) = *value;
    } else if (arg == "--frame-step" || arg == "--pixel-step") {
      const auto text = next_value();
      const auto value = text ? parse_integer(*text) : std::nullopt;
      if (!value || *value < 1 || *value > 1000000) {
        return usage_error(arg + " needs a whole number >= 1");
      }
      (arg == "--frame-step" ? args.samples.frame_step : args.samples.pixel_step) =
          static_cast<int>(*value);
    } else if (arg.size() > 1 && arg[0] == '-') {
      return usage_error("unknown option " + arg);
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 1) {
    return usage_error("expected one MESH file, got " + std::to_string(positional.size()));
  }
  args.mesh = positional[0];
  if (args.sequence.empty()) {
    if (!args.scene) return usage_error("--scene is required (or --sequence)");
    if (!args.seed) return usage_error("--seed is required (or --sequence)");
    if (args.groundtruth.empty()) return usage_error("--groundtruth is required (or --sequence)");
  }
  return std::nullopt;
}

// Scene, seed, poses and camera as recorded in --sequence DIR, where the options left them unset:
// the exit status on an input error, nothing when read.
std::optional<int> read_sequence(Arguments& args, imufusion::Intrinsics& intrinsics,
                                 imufusion::Trajectory& poses) {
  // Scene, seed, poses and camera as recorded; explicit options override them below.
  imufusion::SequenceOptions open_options;
  open_options.load_color = false;
  if (args.intrinsics) {
    open_options.intrinsics = imufusion::Intrinsics{(*args.intrinsics)[0], (*args.intrinsics)[1],
                                                    (*args.intrinsics)[2], (*args.intrinsics)[3]};
  }
  auto reader = imufusion::SequenceReader::open(args.sequence, open_options);
  if (!reader.ok()) {
    std::cerr << "imufusion-mesh-eval: " << reader.error().describe() << "\n";
    return kExitInputError;
  }
  const imufusion::SequenceInfo& info = reader->info();
  const auto find = [&](const char* key) -> std::string {
    const auto it = info.info.find(key);
    return it == info.info.end() ? std::string() : it->second;
  };
  if (!args.scene) {
    args.scene = imufusion::synth::parse_scene_kind(find("scene"));
    if (!args.scene) {
      std::cerr << "imufusion-mesh-eval: " << args.sequence
                << "/info.txt names no synthetic scene ('scene room|wall|fast'); pass --scene\n";
      return kExitInputError;
    }
  }
  if (!args.seed) {
    const auto seed = parse_integer(find("seed"));
    if (!seed || *seed < 0) {
      std::cerr << "imufusion-mesh-eval: " << args.sequence
                << "/info.txt has no 'seed N' line; pass --seed\n";
      return kExitInputError;
    }
    args.seed = static_cast<std::uint64_t>(*seed);
  }
  if (args.groundtruth.empty()) {
    if (!reader->has_ground_truth()) {
      std::cerr << "imufusion-mesh-eval: " << args.sequence << " has no groundtruth.txt\n";
      return kExitInputError;
    }
    poses = reader->ground_truth();
  }
  if (reader->intrinsics()) intrinsics = *reader->intrinsics();
  return std::nullopt;
}

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

void print_json(const Arguments& args, const imufusion::Mesh& mesh, std::size_t poses,
                const imufusion::MeshAccuracy& result) {
  // NaN (a mesh without area) has no JSON form: null.
  auto number = [](double value) {
    return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
  };
  nlohmann::json out = {
      {"mesh", args.mesh},
      {"vertices", mesh.vertices.size()},
      {"triangles", mesh.triangles.size()},
      {"scene", imufusion::synth::to_string(*args.scene)},
      {"poses", poses},
      {"reference_points", result.reference_points},
      {"mesh_samples", result.mesh_samples},
      {"accuracy_mean_m", number(result.accuracy_mean)},
      {"accuracy_median_m", number(result.accuracy_median)},
      {"accuracy_p90_m", number(result.accuracy_p90)},
      {"completeness", result.completeness},
      {"completeness_threshold_m", result.completeness_threshold},
  };
  std::cout << imufusion::tools::json_text(out) << "\n";
}

void print_text(const Arguments& args, const imufusion::Mesh& mesh, std::size_t poses,
                const imufusion::MeshAccuracy& result) {
  std::cout << "mesh          " << args.mesh << ": " << mesh.vertices.size() << " vertices, "
            << mesh.triangles.size() << " triangles\n";
  std::cout << "reference     " << result.reference_points << " true-surface points seen from "
            << poses << " poses (scene " << imufusion::synth::to_string(*args.scene) << ")\n";
  std::cout << "accuracy      mean " << format("%.4f", result.accuracy_mean) << "  median "
            << format("%.4f", result.accuracy_median) << "  p90 "
            << format("%.4f", result.accuracy_p90) << " m (" << result.mesh_samples
            << " mesh samples)\n";
  std::cout << "completeness  " << format("%.4f", result.completeness) << " within "
            << format("%g", result.completeness_threshold) << " m\n";
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  if (const auto status = parse_arguments(argc, argv, args)) return *status;

  auto mesh = imufusion::read_mesh(args.mesh);
  if (!mesh.ok()) {
    std::cerr << "imufusion-mesh-eval: " << mesh.error().describe() << "\n";
    return kExitInputError;
  }
  imufusion::Intrinsics intrinsics = imufusion::synth::default_intrinsics(640, 480);
  imufusion::Trajectory poses;
  if (!args.sequence.empty()) {
    if (const auto status = read_sequence(args, intrinsics, poses)) return *status;
  }
  if (!args.groundtruth.empty()) {
    auto read = imufusion::read_trajectory(args.groundtruth);
    if (!read.ok()) {
      std::cerr << "imufusion-mesh-eval: ground truth " << args.groundtruth << ": "
                << read.error().describe() << "\n";
      return kExitInputError;
    }
    poses = std::move(read).value();
  }
  if (args.size) {
    const imufusion::Intrinsics scaled =
        imufusion::synth::default_intrinsics(args.size->first, args.size->second);
    if (args.sequence.empty()) intrinsics = scaled;
    intrinsics.width = scaled.width;
    intrinsics.height = scaled.height;
  }
  if (args.intrinsics) {
    intrinsics.fx = (*args.intrinsics)[0];
    intrinsics.fy = (*args.intrinsics)[1];
    intrinsics.cx = (*args.intrinsics)[2];
    intrinsics.cy = (*args.intrinsics)[3];
  }
  const imufusion::synth::Scene scene = imufusion::synth::make_scene(*args.scene, *args.seed);
  const auto reference = imufusion::observed_surface_points(scene, poses, intrinsics, args.samples);
  if (reference.empty()) {
    std::cerr << "imufusion-mesh-eval: the " << poses.size() << " poses of "
              << (args.groundtruth.empty() ? args.sequence : args.groundtruth)
              << " see no surface within the sensor's range\n";
    return kExitInputError;
  }
  auto result = imufusion::evaluate_mesh(*mesh, scene, reference, args.eval);
  if (!result.ok()) {
    std::cerr << "imufusion-mesh-eval: " << result.error().describe() << "\n";
    return kExitInputError;
  }

  if (args.json) {
    print_json(args, *mesh, poses.size(), *result);
  } else {
    print_text(args, *mesh, poses.size(), *result);
  }
  return 0;
}
