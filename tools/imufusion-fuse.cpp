// imufusion-fuse SEQUENCE [options]
//
// Fuses a sequence into the sparse TSDF volume with KNOWN poses (no tracking): ground truth by
// default, or any TUM trajectory (--poses), e.g. from external tracking. Fuses through the
// Reconstructor (fuse_with_pose), as imufusion-scan --poses does, and writes the same model
// outputs (model_outputs.hpp) into --out DIR, replaced as one set (io/output_set.hpp): the mesh
// (.glb and .ply), a shaded preview from the last fused pose, an overview from outside the
// scene, and summary.json; for synthetic sequences also the mesh's accuracy and completeness.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli_common.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/mesh_eval.hpp"
#include "imufusion/presets.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"
#include "io/atomic_file.hpp"
#include "io/output_set.hpp"
#include "json_text.hpp"
#include "model_outputs.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

using tools::fail;

struct Options {
  fs::path sequence;
  fs::path poses;
  fs::path out = "fused";
  SensorPreset sensor = SensorPreset::kKinect;
  std::optional<float> voxel_size;  // the preset's when not given
  long max_frames = -1;
  std::string device;
  bool quiet = false;
};

int usage(std::ostream& out, int code) {
  out << "usage: imufusion-fuse SEQUENCE [--poses FILE] [--out DIR] [--voxel-size M] [--frames N]\n"
         "                      [--sensor kinect|phone-tof] [--device NAME|INDEX] [--quiet]\n"
         "Fuses SEQUENCE with known camera-to-world poses (default: its groundtruth.txt; TUM\n"
         "format), writes DIR/mesh.glb, mesh.ply, preview.png, overview.png and summary.json.\n"
         "--sensor picks the preset (default kinect; phone-tof: 240x180 phone ToF), whose voxel\n"
         "size applies unless --voxel-size is given.\n";
  return code;
}

// Parses the command line into `opt`; returns -1 to fuse, else the exit code (0 for --help).
int parse(int argc, char** argv, Options& opt) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (a == "-h" || a == "--help") return usage(std::cout, 0);
    if (a == "--quiet") {
      opt.quiet = true;
      continue;
    }
    if (a.size() > 1 && a[0] == '-') {
      const char* v = next();
      if (v == nullptr) return (std::cerr << a << " needs a value\n", usage(std::cerr, 2));
      char* end = nullptr;
      if (a == "--poses")
        opt.poses = v;
      else if (a == "--out")
        opt.out = v;
      else if (a == "--device")
        opt.device = v;
      else if (a == "--voxel-size") {
        opt.voxel_size = std::strtof(v, &end);
        if (*end != '\0' || !(*opt.voxel_size > 0))
          return (std::cerr << "bad --voxel-size " << v << "\n", 2);
      } else if (a == "--sensor") {
        const auto sensor = parse_sensor_preset(v);
        if (!sensor) return (std::cerr << "bad --sensor " << v << " (kinect or phone-tof)\n", 2);
        opt.sensor = *sensor;
      } else if (a == "--frames") {
        opt.max_frames = std::strtol(v, &end, 10);
        if (*end != '\0' || opt.max_frames <= 0)
          return (std::cerr << "bad --frames " << v << "\n", 2);
      } else {
        std::cerr << "unknown option " << a << "\n";
        return usage(std::cerr, 2);
      }
    } else if (opt.sequence.empty()) {
      opt.sequence = a;
    } else {
      return usage(std::cerr, 2);
    }
  }
  return opt.sequence.empty() ? usage(std::cerr, 2) : -1;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The outputs of a fusion, replaced as one set; summary.json, last, marks the set complete.
std::vector<std::string> fuse_outputs() {
  std::vector<std::string> names(std::begin(tools::kModelOutputs), std::end(tools::kModelOutputs));
  names.push_back("summary.json");
  return names;
}

ReconstructorConfig fuse_config(const Options& opt, const SequenceReader& reader) {
  Intrinsics k = *reader.intrinsics();
  k.width = reader.info().width;
  k.height = reader.info().height;
  // The poses are given: nothing to track, no IMU.
  ReconstructorConfig config = preset_config(opt.sensor, k, /*with_imu=*/false);
  if (opt.voxel_size) config.volume.voxel_size = *opt.voxel_size;
  config.device.selector = opt.device;
  return config;
}

// What the fusion counted over its frames.
struct FuseRun {
  std::size_t frames = 0;        // read (--frames at most)
  std::size_t fused = 0;         // fused at a known pose
  std::size_t without_pose = 0;  // no pose within 20 ms: skipped
  std::uint64_t pool_full = 0;   // IntegrationStats::pool_full summed over the frames
  std::uint64_t table_full = 0;  // IntegrationStats::table_full summed
  std::vector<double> frame_ms;  // wall ms of each fused frame
  std::map<std::string, std::vector<double>> kernel_ms;  // GPU ms of each kernel per frame
};

// Fuses the sequence's frames at their known poses; returns the error message, empty on success.
std::string fuse_frames(const Options& opt, SequenceReader& reader, const Trajectory& poses,
                        Reconstructor& rec, FuseRun& run) {
  run.frames = opt.max_frames > 0 ? std::min<std::size_t>(reader.frame_count(),
                                                          static_cast<std::size_t>(opt.max_frames))
                                  : reader.frame_count();
  const bool progress = !opt.quiet && isatty(STDERR_FILENO);
  for (std::size_t i = 0; i < run.frames; ++i) {
    auto frame = reader.next();
    if (!frame) return frame.error().describe();
    auto result = tools::fuse_at_known_pose(rec, poses, *frame);
    if (!result) return "frame " + std::to_string(i) + ": " + result.error().describe();
    if (!*result) {
      ++run.without_pose;
      continue;
    }
    const FrameResult& r = **result;
    run.frame_ms.push_back(r.timings.total_ms);
    for (const KernelTiming& t : r.timings.kernels) run.kernel_ms[t.kernel].push_back(t.gpu_ms);
    run.pool_full += r.integration.pool_full;
    run.table_full += r.integration.table_full;
    ++run.fused;
    if (progress) std::cerr << "\rfused " << run.fused << "/" << run.frames << std::flush;
  }
  if (progress) std::cerr << "\n";
  return {};
}

nlohmann::json summary_json(const Options& opt, const Reconstructor& rec, const FuseRun& run) {
  nlohmann::json summary;
  summary["sequence"] = opt.sequence.string();
  summary["poses"] = opt.poses.empty() ? "groundtruth.txt" : opt.poses.string();
  summary["device"] = rec.device().name;
  summary["frames"] = run.frames;
  summary["frames_fused"] = run.fused;
  summary["frames_without_pose"] = run.without_pose;
  summary["voxel_size"] = rec.config().volume.voxel_size;
  summary["truncation"] = rec.config().volume.truncation();
  summary["blocks_allocated"] = rec.allocated_blocks();
  summary["pool_blocks_reserved"] = rec.pool_blocks();
  summary["volume_bytes"] = rec.memory_bytes();
  summary["bytes_per_voxel"] = 8;
  summary["pool_full_events"] = run.pool_full;
  summary["table_full_events"] = run.table_full;
  summary["median_frame_ms"] = median(run.frame_ms);
  for (const auto& [kernel, ms] : run.kernel_ms) summary["median_gpu_ms"][kernel] = median(ms);
  return summary;
}

// Synthetic sequences name their scene: measures the mesh against the true surface the fused
// frames saw, into `summary`.
void add_mesh_accuracy(const SequenceReader& reader, const Reconstructor& rec, const Mesh& mesh,
                       nlohmann::json& summary) {
  const auto& info = reader.info().info;
  auto scene_name = info.find("scene");
  auto seed = info.find("seed");
  if (scene_name == info.end() || seed == info.end()) return;
  auto kind = synth::parse_scene_kind(scene_name->second);
  if (!kind) return;
  const synth::Scene scene =
      synth::make_scene(*kind, std::strtoull(seed->second.c_str(), nullptr, 10));
  const auto points = observed_surface_points(scene, rec.trajectory(), rec.config().intrinsics);
  auto accuracy = evaluate_mesh(mesh, scene, points);
  if (!accuracy) return;
  summary["mesh_accuracy_mean"] = accuracy->accuracy_mean;
  summary["mesh_accuracy_median"] = accuracy->accuracy_median;
  summary["mesh_completeness"] = accuracy->completeness;
  summary["mesh_completeness_threshold"] = accuracy->completeness_threshold;
}

// Writes the mesh, the views and summary.json into the set's staging directory; returns the
// mesh's triangles (0: nothing written), or the first failure.
Result<std::size_t> write_outputs(const io::OutputSet& set, const SequenceReader& reader,
                                  Reconstructor& rec, nlohmann::json& summary) {
  const auto m0 = std::chrono::steady_clock::now();
  auto mesh = rec.extract_mesh();
  if (!mesh) return mesh.error();
  summary["mesh_ms"] =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - m0).count();
  if (mesh->triangles.empty()) return std::size_t{0};
  summary["mesh_vertices"] = mesh->vertices.size();
  summary["mesh_triangles"] = mesh->triangles.size();
  auto pictures_ms = tools::write_model_outputs(set, rec, *mesh, tools::path_of(rec.trajectory()));
  if (!pictures_ms) return pictures_ms.error();
  summary["pictures_ms"] = *pictures_ms;
  add_mesh_accuracy(reader, rec, *mesh, summary);
  IMUFUSION_RETURN_IF_ERROR(
      io::write_text_atomically(set.staged("summary.json"), tools::json_text(summary) + "\n"));
  return mesh->triangles.size();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (const int rc = parse(argc, argv, opt); rc >= 0) return rc;

  auto reader = SequenceReader::open(opt.sequence);
  if (!reader) return fail(reader.error().describe());
  if (!reader->intrinsics())
    return fail((opt.sequence / "calibration.txt").string() + " is missing");
  Trajectory poses;
  if (!opt.poses.empty()) {
    auto read = read_trajectory(opt.poses);
    if (!read) return fail(read.error().describe());
    poses = std::move(*read);
  } else if (reader->has_ground_truth()) {
    poses = reader->ground_truth();
  } else {
    return fail((opt.sequence / "groundtruth.txt").string() + " is missing: pass --poses FILE");
  }
  auto outputs = io::OutputSet::begin(opt.out, fuse_outputs());
  if (!outputs) return fail(outputs.error().describe());
  auto rec = Reconstructor::create(fuse_config(opt, *reader));
  if (!rec) return fail(rec.error().describe());

  FuseRun run;
  if (const std::string error = fuse_frames(opt, *reader, poses, *rec, run); !error.empty())
    return fail(error);
  if (run.fused == 0)
    return fail("no frame has a pose within 20 ms in " +
                (opt.poses.empty() ? (opt.sequence / "groundtruth.txt") : opt.poses).string());
  nlohmann::json summary = summary_json(opt, *rec, run);
  auto triangles = write_outputs(*outputs, *reader, *rec, summary);
  if (!triangles) return fail(triangles.error().describe());
  if (*triangles == 0) return fail("the fused volume holds no surface (no triangles)");
  if (auto s = outputs->commit(); !s) return fail(s.error().describe());
  std::printf(
      "fused %zu of %zu frames on %s: %u blocks of a pool of %u (%.1f MiB of volume), mesh %zu "
      "triangles -> %s\n",
      run.fused, run.frames, rec->device().name.c_str(), rec->allocated_blocks(),
      rec->pool_blocks(), double(rec->memory_bytes()) / (1024.0 * 1024.0), *triangles,
      outputs->final_path("mesh.glb").string().c_str());
  if (summary.contains("mesh_completeness"))
    std::printf("mesh vs true surface: accuracy %.2f mm mean, completeness %.1f%% within %.0f mm\n",
                1000 * summary["mesh_accuracy_mean"].get<double>(),
                100 * summary["mesh_completeness"].get<double>(),
                1000 * summary["mesh_completeness_threshold"].get<double>());
  return 0;
}
