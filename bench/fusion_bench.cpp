// fusion_bench: the sparse TSDF volume at 640x480 and 1 cm voxels on the synthetic furnished
// room, fused with ground-truth poses. Prints the median GPU time per frame of allocation,
// integration and raycast (its range pass and its march), the mean march steps per ray, the CPU
// time of meshing the whole volume, and the blocks and bytes used after the scan.
//
//   fusion_bench [--frames N] [--raycast-every N] [--voxel-size M]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "imufusion/fusion.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/synth.hpp"

using namespace imufusion;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 150, raycast_every = 10;
  float voxel_size = 0.01f;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--frames")
      frames = std::atoi(argv[i + 1]);
    else if (a == "--raycast-every")
      raycast_every = std::max(1, std::atoi(argv[i + 1]));
    else if (a == "--voxel-size")
      voxel_size = static_cast<float>(std::atof(argv[i + 1]));
    else {
      std::fprintf(stderr,
                   "usage: fusion_bench [--frames N] [--raycast-every N] [--voxel-size M]\n");
      return 2;
    }
  }
  const Intrinsics k = synth::default_intrinsics(640, 480);
  const synth::Scene scene = synth::make_scene(synth::SceneKind::kRoom, 1);
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 1);
  VolumeConfig config;
  config.voxel_size = voxel_size;
  auto fusion = TsdfFusion::create(config, PreprocessConfig{}, k);
  if (!fusion) {
    std::fprintf(stderr, "%s\n", fusion.error().describe().c_str());
    return 1;
  }
  std::map<std::string, std::vector<double>> ms;
  std::uint64_t pool_full = 0;
  std::uint64_t steps = 0, rays = 0, marched = 0;
  for (int f = 0; f < frames; ++f) {
    const Eigen::Isometry3d T = motion.pose_at(f / 30.0);
    const synth::RenderedFrame frame =
        synth::render_frame(scene, T, k, synth::SensorModel{}, 100 + f, true);
    std::vector<KernelTiming> timings;
    auto stats = fusion->integrate(frame.depth, &frame.color, T, &timings);
    if (!stats) {
      std::fprintf(stderr, "%s\n", stats.error().describe().c_str());
      return 1;
    }
    pool_full += stats->pool_full;
    for (const KernelTiming& t : timings)
      if (t.kernel.rfind("volume_", 0) == 0) ms[t.kernel].push_back(t.gpu_ms);
    if (f % raycast_every == raycast_every - 1) {
      std::vector<KernelTiming> rt;
      auto images = fusion->raycast(T, std::nullopt, &rt);
      if (!images) {
        std::fprintf(stderr, "%s\n", images.error().describe().c_str());
        return 1;
      }
      double total = 0;
      for (const KernelTiming& t : rt) {
        ms[t.kernel].push_back(t.gpu_ms);
        total += t.gpu_ms;
      }
      ms["raycast total"].push_back(total);
      auto ray_steps = fusion->last_raycast_steps();
      if (!ray_steps) {
        std::fprintf(stderr, "%s\n", ray_steps.error().describe().c_str());
        return 1;
      }
      for (std::uint32_t n : *ray_steps) {
        steps += n;
        marched += n > 0 ? 1 : 0;
      }
      rays += ray_steps->size();
    }
  }
  auto snapshot = fusion->snapshot();
  if (!snapshot) return 1;
  const auto m0 = std::chrono::steady_clock::now();
  auto mesh = extract_mesh(*snapshot);
  const double mesh_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - m0).count();
  if (!mesh) return 1;
  std::printf("device %s, 640x480, voxel %.3f m, %d frames of the synthetic room\n",
              fusion->device().name.c_str(), voxel_size, frames);
  for (const char* kernel : {"volume_allocate", "volume_integrate", "volume_raycast_range",
                             "volume_raycast", "raycast total"})
    std::printf("  %-20s median %8.2f ms per frame (%zu samples)\n", kernel, median(ms[kernel]),
                ms[kernel].size());
  std::printf(
      "  march steps per ray: mean %.1f over all rays, %.1f over the %.1f%% of rays that march\n",
      double(steps) / double(std::max<std::uint64_t>(rays, 1)),
      double(steps) / double(std::max<std::uint64_t>(marched, 1)),
      100.0 * double(marched) / double(std::max<std::uint64_t>(rays, 1)));
  std::printf("  %-17s %8.2f ms (CPU, %zu blocks -> %zu triangles)\n", "marching cubes", mesh_ms,
              snapshot->blocks.size(), mesh->triangles.size());
  std::printf(
      "  blocks allocated %u, voxel memory in use %.1f MiB (8 bytes per voxel), pool + table %.1f "
      "MiB, pool-full events %llu\n",
      fusion->allocated_blocks(), fusion->allocated_blocks() * 512.0 * 8 / (1024 * 1024),
      double(fusion->memory_bytes()) / (1024 * 1024), static_cast<unsigned long long>(pool_full));
  return 0;
}
