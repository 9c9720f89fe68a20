// fusion_bench: the sparse TSDF volume (gpu::TsdfVolume) at 640x480 and 1 cm voxels on the
// synthetic furnished room, fused with ground-truth poses; depth is turned into metres on the
// host, as preprocessing's depth_to_metres does, so that only the volume's kernels run. Prints the
// median GPU time per frame of allocation, integration and raycast (its range pass and its march),
// the mean march steps per ray, the CPU time of meshing the whole volume, and the blocks and bytes
// used after the scan.
//
//   fusion_bench [--frames N] [--raycast-every N] [--voxel-size M]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "gpu/rgba.hpp"
#include "gpu/volume.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/synth.hpp"
#include "vk/buffer.hpp"
#include "vk/context.hpp"

using namespace imufusion;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Raw depth in metres, 0 where unmeasured or outside the preprocessing range.
std::vector<float> depth_metres(const DepthImage& depth, const PreprocessConfig& range) {
  std::vector<float> metres(depth.data.size());
  for (std::size_t i = 0; i < metres.size(); ++i) {
    const auto d = static_cast<float>(depth.data[i] / depth.depth_scale);
    metres[i] = depth.data[i] != 0 && d >= range.min_depth && d <= range.max_depth ? d : 0.0f;
  }
  return metres;
}

// The volume with the buffers its frames and raycasts go through.
struct Bench {
  std::shared_ptr<gpu::Context> context;
  gpu::TsdfVolume volume;
  gpu::Buffer depth, color;                       // a frame's input: metres, RGBA8
  gpu::Buffer vertices, normals, shaded, colors;  // a raycast's output
  std::vector<std::uint32_t> rgba;
  PreprocessConfig range;                         // the depth range, metres
  std::map<std::string, std::vector<double>> ms;  // GPU ms of each kernel per frame or raycast
  std::uint64_t pool_full = 0;
  std::uint64_t steps = 0, rays = 0, marched = 0;  // raycast march steps, rays, rays that march

  static Result<Bench> create(const VolumeConfig& config, const Intrinsics& k) {
    auto created_context = gpu::Context::create();
    if (!created_context) return created_context.error();
    auto created_volume = gpu::TsdfVolume::create(*created_context, config);
    if (!created_volume) return created_volume.error();
    Bench b;
    b.context = *created_context;
    b.volume = std::move(*created_volume);
    const auto pixels = static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height);
    // Device-local as the scanner's, but for the colour that the host writes once per frame.
    for (auto [buffer, bytes, host] : {std::tuple{&b.depth, pixels * 4, false},
                                       {&b.color, pixels * 4, true},
                                       {&b.vertices, pixels * 16, false},
                                       {&b.normals, pixels * 16, false},
                                       {&b.shaded, pixels * 4, false},
                                       {&b.colors, pixels * 4, false}}) {
      auto created = gpu::Buffer::create(b.context, bytes, host);
      if (!created) return created.error();
      *buffer = std::move(*created);
    }
    return b;
  }

  // Fuses a rendered frame seen from T (camera to world).
  Status fuse(const synth::RenderedFrame& frame, const Intrinsics& k, const Eigen::Isometry3d& T) {
    const std::vector<float> metres = depth_metres(frame.depth, range);
    IMUFUSION_RETURN_IF_ERROR(depth.upload(metres.data(), metres.size() * 4));
    IMUFUSION_RETURN_IF_ERROR(gpu::upload_rgba(frame.color, color, rgba));
    std::vector<KernelTiming> timings;
    auto stats = volume.integrate(depth, &color, k, T, &timings);
    if (!stats) return stats.error();
    pool_full += stats->pool_full;
    for (const KernelTiming& t : timings)
      if (t.kernel.rfind("volume_", 0) == 0) ms[t.kernel].push_back(t.gpu_ms);
    return {};
  }

  // Raycasts the model from T, counting the march steps of its rays.
  Status raycast(const Intrinsics& k, const Eigen::Isometry3d& T) {
    std::vector<KernelTiming> rt;
    IMUFUSION_RETURN_IF_ERROR(volume.raycast(k, T, range.min_depth, range.max_depth, vertices,
                                             normals, shaded, colors, &rt));
    double total = 0;
    for (const KernelTiming& t : rt) {
      ms[t.kernel].push_back(t.gpu_ms);
      total += t.gpu_ms;
    }
    ms["raycast total"].push_back(total);
    auto ray_steps = volume.last_raycast_steps();
    if (!ray_steps) return ray_steps.error();
    for (std::uint32_t n : *ray_steps) {
      steps += n;
      marched += n > 0 ? 1 : 0;
    }
    rays += ray_steps->size();
    return {};
  }
};

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
  auto bench = Bench::create(config, k);
  if (!bench) {
    std::fprintf(stderr, "%s\n", bench.error().describe().c_str());
    return 1;
  }
  for (int f = 0; f < frames; ++f) {
    const Eigen::Isometry3d T = motion.pose_at(f / 30.0);
    Status done =
        bench->fuse(synth::render_frame(scene, T, k, synth::SensorModel{}, 100 + f, true), k, T);
    if (done && f % raycast_every == raycast_every - 1) done = bench->raycast(k, T);
    if (!done) {
      std::fprintf(stderr, "%s\n", done.error().describe().c_str());
      return 1;
    }
  }
  const gpu::TsdfVolume& volume = bench->volume;
  auto& ms = bench->ms;
  const std::uint64_t steps = bench->steps, rays = bench->rays, marched = bench->marched;
  auto snapshot = volume.snapshot();
  if (!snapshot) return 1;
  const auto m0 = std::chrono::steady_clock::now();
  auto mesh = extract_mesh(*snapshot);
  const double mesh_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - m0).count();
  if (!mesh) return 1;
  std::printf("device %s, 640x480, voxel %.3f m, %d frames of the synthetic room\n",
              bench->context->info().name.c_str(), voxel_size, frames);
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
      "  blocks allocated %u, voxel memory in use %.1f MiB (8 bytes per voxel), pool of %u blocks "
      "after %u growths + table %.1f MiB, pool-full events %llu\n",
      volume.allocated_blocks(), volume.allocated_blocks() * 512.0 * 8 / (1024 * 1024),
      volume.pool_blocks(), volume.pool_growths(), double(volume.reserved_bytes()) / (1024 * 1024),
      static_cast<unsigned long long>(bench->pool_full));
  // One more growth step of the final pool, half again its size: new buffers, the copy on the
  // device and the wait.
  const std::uint32_t from = volume.pool_blocks();
  const std::uint32_t to = std::min(config.block_capacity, from + from / 2);
  const auto g0 = std::chrono::steady_clock::now();
  if (!bench->volume.reserve_blocks(to)) return 1;
  std::printf(
      "  growth step %u -> %u blocks: %.2f ms\n", from, to,
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - g0).count());
  return 0;
}
