// imufusion-fuse SEQUENCE [options]
//
// Fuses a sequence into the sparse TSDF volume with KNOWN poses (no tracking): ground truth by
// default, or any TUM trajectory (--poses), e.g. from external tracking. Writes the mesh (.glb
// and .ply), a shaded preview from the last fused pose, an overview from outside the scene, and
// summary.json; for synthetic sequences also the mesh's accuracy and completeness.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "imufusion/fusion.hpp"
#include "imufusion/image_io.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/mesh_eval.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"
#include "imufusion/trajectory.hpp"
#include "io/atomic_file.hpp"
#include "json_text.hpp"
#include "overview_pose.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

struct Options {
  fs::path sequence;
  fs::path poses;
  fs::path out = "fused";
  float voxel_size = 0.01f;
  long max_frames = -1;
  std::string device;
  bool quiet = false;
};

int usage(std::ostream& out, int code) {
  out << "usage: imufusion-fuse SEQUENCE [--poses FILE] [--out DIR] [--voxel-size M] [--frames N]\n"
         "                      [--device NAME|INDEX] [--quiet]\n"
         "Fuses SEQUENCE with known camera-to-world poses (default: its groundtruth.txt; TUM\n"
         "format), writes DIR/mesh.glb, mesh.ply, preview.png, overview.png and summary.json.\n";
  return code;
}

int fail(const std::string& message) {
  std::cerr << "error: " << message << "\n";
  return 1;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
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
        if (*end != '\0' || !(opt.voxel_size > 0))
          return (std::cerr << "bad --voxel-size " << v << "\n", 2);
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
  if (opt.sequence.empty()) return usage(std::cerr, 2);

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
  std::error_code ec;
  fs::create_directories(opt.out, ec);
  if (ec) return fail("cannot create " + opt.out.string() + ": " + ec.message());

  auto first = reader->frame(0);
  if (!first) return fail(first.error().describe());
  Intrinsics k = *reader->intrinsics();
  k.width = first->depth.width;
  k.height = first->depth.height;
  VolumeConfig volume;
  volume.voxel_size = opt.voxel_size;
  DeviceOptions device;
  device.selector = opt.device;
  auto fusion = TsdfFusion::create(volume, PreprocessConfig{}, k, device);
  if (!fusion) return fail(fusion.error().describe());

  const std::size_t total =
      opt.max_frames > 0
          ? std::min<std::size_t>(reader->frame_count(), static_cast<std::size_t>(opt.max_frames))
          : reader->frame_count();
  std::map<std::string, std::vector<double>> kernel_ms;
  std::vector<double> frame_ms;
  std::size_t fused = 0, skipped = 0;
  std::uint64_t pool_full = 0, table_full = 0;
  Trajectory used;
  const bool progress = !opt.quiet && isatty(STDERR_FILENO);
  for (std::size_t i = 0; i < total; ++i) {
    auto frame = reader->next();
    if (!frame) return fail(frame.error().describe());
    const StampedPose* pose = find_pose(poses, frame->timestamp);
    if (pose == nullptr) {
      ++skipped;
      continue;
    }
    std::vector<KernelTiming> timings;
    const auto t0 = std::chrono::steady_clock::now();
    auto stats = fusion->integrate(frame->depth, frame->color ? &*frame->color : nullptr,
                                   pose->T_world_camera, &timings);
    if (!stats) return fail("frame " + std::to_string(i) + ": " + stats.error().describe());
    frame_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    for (const KernelTiming& t : timings) kernel_ms[t.kernel].push_back(t.gpu_ms);
    pool_full += stats->pool_full;
    table_full += stats->table_full;
    used.push_back({frame->timestamp, pose->T_world_camera});
    ++fused;
    if (progress) std::cerr << "\rfused " << fused << "/" << total << std::flush;
  }
  if (progress) std::cerr << "\n";
  if (fused == 0)
    return fail("no frame has a pose within 20 ms in " +
                (opt.poses.empty() ? (opt.sequence / "groundtruth.txt") : opt.poses).string());

  auto snapshot = fusion->snapshot();
  if (!snapshot) return fail(snapshot.error().describe());
  const auto m0 = std::chrono::steady_clock::now();
  auto mesh = extract_mesh(*snapshot);
  if (!mesh) return fail(mesh.error().describe());
  const double mesh_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - m0).count();
  if (mesh->triangles.empty()) return fail("the fused volume holds no surface (no triangles)");
  if (auto s = write_glb(opt.out / "mesh.glb", *mesh); !s) return fail(s.error().describe());
  if (auto s = write_ply(opt.out / "mesh.ply", *mesh); !s) return fail(s.error().describe());

  std::vector<KernelTiming> raycast_timing;
  auto preview = fusion->raycast(used.back().T_world_camera, std::nullopt, &raycast_timing);
  if (!preview) return fail(preview.error().describe());
  if (auto s = write_color_png(opt.out / "preview.png", preview->shaded); !s)
    return fail(s.error().describe());
  auto overview = fusion->raycast(tools::overview_pose(*snapshot, used.front().T_world_camera, k),
                                  std::nullopt, nullptr, std::pair{0.1f, 100.0f});
  if (!overview) return fail(overview.error().describe());
  if (auto s = write_color_png(opt.out / "overview.png", overview->shaded); !s)
    return fail(s.error().describe());

  nlohmann::json summary;
  summary["sequence"] = opt.sequence.string();
  summary["poses"] = opt.poses.empty() ? "groundtruth.txt" : opt.poses.string();
  summary["device"] = fusion->device().name;
  summary["frames"] = total;
  summary["frames_fused"] = fused;
  summary["frames_without_pose"] = skipped;
  summary["voxel_size"] = opt.voxel_size;
  summary["truncation"] = volume.truncation();
  summary["blocks_allocated"] = fusion->allocated_blocks();
  summary["volume_bytes"] = fusion->memory_bytes();
  summary["bytes_per_voxel"] = 8;
  summary["pool_full_events"] = pool_full;
  summary["table_full_events"] = table_full;
  summary["mesh_vertices"] = mesh->vertices.size();
  summary["mesh_triangles"] = mesh->triangles.size();
  summary["mesh_ms"] = mesh_ms;
  summary["median_frame_ms"] = median(frame_ms);
  for (const auto& [kernel, ms] : kernel_ms) summary["median_gpu_ms"][kernel] = median(ms);
  if (!raycast_timing.empty())
    summary["median_gpu_ms"]["volume_raycast"] = raycast_timing.front().gpu_ms;

  // Synthetic sequences name their scene: measure the mesh against the true surface.
  const auto& info = reader->info().info;
  auto scene_name = info.find("scene");
  auto seed = info.find("seed");
  if (scene_name != info.end() && seed != info.end()) {
    if (auto kind = synth::parse_scene_kind(scene_name->second)) {
      const synth::Scene scene =
          synth::make_scene(*kind, std::strtoull(seed->second.c_str(), nullptr, 10));
      const auto points = observed_surface_points(scene, used, k);
      auto accuracy = evaluate_mesh(*mesh, scene, points);
      if (accuracy) {
        summary["mesh_accuracy_mean"] = accuracy->accuracy_mean;
        summary["mesh_accuracy_median"] = accuracy->accuracy_median;
        summary["mesh_completeness"] = accuracy->completeness;
        summary["mesh_completeness_threshold"] = accuracy->completeness_threshold;
      }
    }
  }
  if (auto s =
          io::write_text_atomically(opt.out / "summary.json", tools::json_text(summary) + "\n");
      !s)
    return fail(s.error().describe());
  std::printf(
      "fused %zu of %zu frames on %s: %u blocks (%.1f MiB of volume), mesh %zu triangles -> %s\n",
      fused, total, fusion->device().name.c_str(), fusion->allocated_blocks(),
      double(fusion->memory_bytes()) / (1024.0 * 1024.0), mesh->triangles.size(),
      (opt.out / "mesh.glb").string().c_str());
  if (summary.contains("mesh_completeness"))
    std::printf("mesh vs true surface: accuracy %.2f mm mean, completeness %.1f%% within %.0f mm\n",
                1000 * summary["mesh_accuracy_mean"].get<double>(),
                100 * summary["mesh_completeness"].get<double>(),
                1000 * summary["mesh_completeness_threshold"].get<double>());
  return 0;
}
