// The GPU sparse TSDF volume (volume_allocate / volume_integrate / volume_raycast) against its
// CPU reference (src/reference/volume_reference), on the same float depth maps, and the fused
// model against exact analytic depth. Tolerances:
//   allocation: the block sets may differ by <= 0.5% of the blocks. The GPU samples each ray
//     segment in float, the reference in double; a sample within ~1e-7 m of a block face can
//     land in the neighbouring block, and a block touched only by such a sample differs.
//   integration: < 0.5% of the observed voxels may be outliers: observed in one volume only,
//     weights differing, |tsdf_gpu - tsdf_ref| * truncation > 1 mm, or a colour channel off by
//     more than 1. Float vs double projection puts a voxel into the neighbouring pixel when it
//     projects within ~1e-5 px of a pixel border; at a depth edge that changes its distance.
//     Colour rounding (float vs double, 8-bit) allows 1 unit.
//   raycast (GPU and reference on the same GPU snapshot): hit / miss agree on >= 99% of the
//     pixels, and where both hit the vertices agree to 1 mm (float vs double marching lands on
//     slightly different samples; the linear refinement brings them together); normals within
//     0.01, colour and shading within 1 unit, each on >= 99% of those pixels.
//   analytic: the median and 95th percentile of |raycast depth - exact depth| stay below a voxel;
//     the raycast normals' angle to the exact ones has a median below 6 deg and a 90th
//     percentile below 15 deg.
// Hash table and pool overflows are exercised with tiny tables: nothing may hang, no more blocks
// than the capacity, the blocks that got storage hold what the reference computes for them, and
// every block a frame touched is reported as fused or refused (same budget as allocation).
// Measured on lavapipe, the comparisons are near exact: 0 block differences, at most 1 outlier
// voxel in ~300k, 0 raycast disagreements.

#include "gpu/volume.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <numbers>
#include <optional>
#include <vector>

#include "vk/buffer.hpp"
#include "gpu_test_env.hpp"
#include "imufusion/fusion.hpp"
#include "imufusion/synth.hpp"
#include "reference/volume_reference.hpp"

namespace imufusion {
namespace {

using reference::CpuVolume;
using test::GpuTest;
using Blocks = std::vector<Eigen::Vector3i>;

constexpr double kBudget = 0.005;  // outlier fraction allowed (see the header)

double budget(std::size_t count) { return kBudget * static_cast<double>(count); }

Eigen::Isometry3d look_at(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - position).normalized();                // optical axis
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();  // right (z up)
  const Eigen::Vector3d y = z.cross(x);                                      // down
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << x, y, z;
  T.translation() = position;
  return T;
}

// A camera on a circle around the objects, `angle` radians, looking at their middle.
Eigen::Isometry3d orbit_pose(double angle, double radius = 1.3, double height = 0.75) {
  const Eigen::Vector3d target(0.1, 0.0, 0.2);
  return look_at(
      target + Eigen::Vector3d(radius * std::cos(angle), radius * std::sin(angle), height), target);
}

// A sphere and a yawed box on a checkered floor (world z up, metres).
synth::Scene objects_scene() {
  synth::Scene scene;
  synth::Sphere sphere;
  sphere.center = Eigen::Vector3d(-0.15, 0.1, 0.25);
  sphere.radius = 0.25;
  sphere.material.color = Eigen::Vector3f(0.8f, 0.3f, 0.2f);
  scene.spheres.push_back(sphere);
  synth::Box box;
  box.center = Eigen::Vector3d(0.35, -0.15, 0.2);
  box.half_extents = Eigen::Vector3d(0.15, 0.2, 0.2);
  box.yaw = 0.4;
  box.material.color = Eigen::Vector3f(0.2f, 0.5f, 0.9f);
  box.material.color2 = Eigen::Vector3f(0.9f, 0.9f, 0.2f);
  box.material.checker_size = 0.07;
  scene.boxes.push_back(box);
  synth::Plane floor;
  floor.material.color = Eigen::Vector3f(0.3f, 0.3f, 0.3f);
  floor.material.color2 = Eigen::Vector3f(0.9f, 0.9f, 0.9f);
  floor.material.checker_size = 0.2;
  scene.planes.push_back(floor);
  return scene;
}

// Exact z-depth (metres), cut at `max_depth` so that the infinite floor stays small.
FloatImage exact_depth(const synth::Scene& scene, const Eigen::Isometry3d& T_world_camera,
                       const Intrinsics& k, double max_depth = 2.5) {
  FloatImage depth = synth::raycast_depth(scene, T_world_camera, k);
  for (float& d : depth.data) {
    if (d > max_depth) d = 0.0f;
  }
  return depth;
}

struct Frame {
  FloatImage depth;
  ColorImage color;
  Eigen::Isometry3d T_world_camera;
};

Frame make_frame(const synth::Scene& scene, const Eigen::Isometry3d& T_world_camera,
                 const Intrinsics& k, bool with_color) {
  Frame frame{exact_depth(scene, T_world_camera, k), {}, T_world_camera};
  if (with_color) frame.color = synth::render_color(scene, T_world_camera, k);
  return frame;
}

// A GPU volume with its input buffers.
struct GpuVolume {
  gpu::TsdfVolume volume;
  gpu::Buffer depth, color;
  Intrinsics intrinsics;

  static std::optional<GpuVolume> create(const std::shared_ptr<gpu::Context>& context,
                                         const VolumeConfig& config, const Intrinsics& k) {
    auto volume = gpu::TsdfVolume::create(context, config, 8, 8);
    if (!volume) {
      ADD_FAILURE() << volume.error().describe();
      return std::nullopt;
    }
    const auto pixels = static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height);
    auto depth = gpu::Buffer::create(context, pixels * 4);
    auto color = gpu::Buffer::create(context, pixels * 4);
    if (!depth || !color) {
      ADD_FAILURE() << "input buffers: " << (depth ? color.error() : depth.error()).describe();
      return std::nullopt;
    }
    return GpuVolume{std::move(*volume), std::move(*depth), std::move(*color), k};
  }

  IntegrationStats integrate(const Frame& frame) {
    EXPECT_TRUE(depth.upload(frame.depth.data.data(), frame.depth.data.size() * 4).ok());
    const bool has_color = !frame.color.data.empty();
    if (has_color) {
      std::vector<std::uint32_t> rgba(frame.depth.data.size());
      for (std::size_t i = 0; i < rgba.size(); ++i) {
        rgba[i] = std::uint32_t{frame.color.data[3 * i]} |
                  (std::uint32_t{frame.color.data[3 * i + 1]} << 8) |
                  (std::uint32_t{frame.color.data[3 * i + 2]} << 16) | 0xFF000000u;
      }
      EXPECT_TRUE(color.upload(rgba.data(), rgba.size() * 4).ok());
    }
    auto stats =
        volume.integrate(depth, has_color ? &color : nullptr, intrinsics, frame.T_world_camera);
    EXPECT_TRUE(stats.ok()) << stats.error().describe();
    return stats.ok() ? *stats : IntegrationStats{};
  }

  HostVolume snapshot() const {
    auto host = volume.snapshot();
    EXPECT_TRUE(host.ok()) << host.error().describe();
    return host.ok() ? *host : HostVolume{};
  }

  RaycastImages raycast(const Intrinsics& k, const Eigen::Isometry3d& T_world_camera,
                        float near_depth, float far_depth) {
    const auto pixels = static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height);
    const std::shared_ptr<gpu::Context>& context = volume.context();
    auto vertices = gpu::Buffer::create(context, pixels * 16);
    auto normals = gpu::Buffer::create(context, pixels * 16);
    auto shaded = gpu::Buffer::create(context, pixels * 4);
    auto colors = gpu::Buffer::create(context, pixels * 4);
    if (!vertices || !normals || !shaded || !colors) {
      ADD_FAILURE() << "raycast output buffers could not be created";
      return {};
    }
    const Status status = volume.raycast(k, T_world_camera, near_depth, far_depth, *vertices,
                                         *normals, *shaded, *colors);
    EXPECT_TRUE(status.ok()) << status.error().describe();
    RaycastImages out;
    out.vertices.width = out.normals.width = out.shaded.width = out.color.width = k.width;
    out.vertices.height = out.normals.height = out.shaded.height = out.color.height = k.height;
    out.vertices.data.resize(pixels);
    out.normals.data.resize(pixels);
    EXPECT_TRUE(vertices->download(out.vertices.data.data(), pixels * 16).ok());
    EXPECT_TRUE(normals->download(out.normals.data.data(), pixels * 16).ok());
    for (auto [buffer, image] : {std::pair{&*shaded, &out.shaded}, {&*colors, &out.color}}) {
      auto rgba = buffer->download_as<std::uint32_t>(pixels);
      EXPECT_TRUE(rgba.ok());
      image->data.resize(3 * pixels);
      for (std::size_t i = 0; rgba.ok() && i < pixels; ++i) {
        for (std::size_t c = 0; c < 3; ++c)
          image->data[3 * i + c] = static_cast<std::uint8_t>(((*rgba)[i] >> (8 * c)) & 0xFF);
      }
    }
    return out;
  }
};

Blocks sorted_blocks(const HostVolume& host) {
  Blocks blocks;
  for (const VolumeBlock& b : host.blocks) blocks.push_back(b.coord);
  std::sort(blocks.begin(), blocks.end(), reference::block_less);
  return blocks;
}

std::size_t symmetric_difference(const Blocks& a, const Blocks& b) {
  Blocks out;
  std::set_symmetric_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out),
                                reference::block_less);
  return out.size();
}

bool has_duplicates(Blocks blocks) {
  return std::adjacent_find(blocks.begin(), blocks.end()) != blocks.end();
}

struct VoxelDiff {
  std::size_t observed = 0;                                 // voxels observed in either volume
  std::size_t status = 0, tsdf = 0, weight = 0, color = 0;  // kinds of disagreement
  std::size_t outliers = 0;                                 // voxels with any disagreement
};

std::ostream& operator<<(std::ostream& os, const VoxelDiff& d) {
  return os << d.outliers << " outliers of " << d.observed << " observed voxels (status "
            << d.status << ", tsdf " << d.tsdf << ", weight " << d.weight << ", colour " << d.color
            << ")";
}

// Voxel-by-voxel comparison over the union of both volumes' blocks.
VoxelDiff compare_voxels(const HostVolume& gpu, const CpuVolume& ref) {
  VoxelDiff diff;
  const CpuVolume gpu_volume = CpuVolume::from_host_volume(gpu, 65535);
  Blocks all = sorted_blocks(gpu);
  for (const Eigen::Vector3i& b : ref.block_coords()) all.push_back(b);
  std::sort(all.begin(), all.end(), reference::block_less);
  all.erase(std::unique(all.begin(), all.end()), all.end());
  for (const Eigen::Vector3i& b : all) {
    for (int i = 0; i < kBlockVoxels; ++i) {
      const Eigen::Vector3i l = kBlockSide * b + Eigen::Vector3i(i % 8, (i / 8) % 8, i / 64);
      const reference::StoredVoxel* g = gpu_volume.voxel(l);
      const reference::StoredVoxel* r = ref.voxel(l);
      const bool g_seen = g != nullptr && g->weight > 0, r_seen = r != nullptr && r->weight > 0;
      if (!g_seen && !r_seen) continue;
      ++diff.observed;
      bool bad = false;
      if (g_seen != r_seen) {
        ++diff.status;
        bad = true;
      } else {
        if (std::abs(g->tsdf - r->tsdf) / 32767.0 * ref.truncation() > 0.001)
          ++diff.tsdf, bad = true;
        if (g->weight != r->weight) ++diff.weight, bad = true;
        for (std::size_t c = 0; c < 3; ++c) {
          if (std::abs(int{g->color[c]} - int{r->color[c]}) > 1) {
            ++diff.color;
            bad = true;
            break;
          }
        }
      }
      diff.outliers += bad ? 1 : 0;
    }
  }
  return diff;
}

VolumeConfig small_config() {
  VolumeConfig config;
  config.voxel_size = 0.01f;
  config.truncation_voxels = 4.0f;
  config.max_weight = 64;
  config.block_capacity = 8192;
  config.hash_slots = 16384;
  return config;
}

TEST_F(GpuTest, VolumeAllocationMatchesReference) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  for (int f = 0; f < 3; ++f) {
    const Frame frame = make_frame(scene, orbit_pose(0.5 * f), k, false);
    const IntegrationStats stats = gpu.integrate(frame);
    const auto allocation = ref.allocate(frame.depth, k, frame.T_world_camera);
    const Blocks gpu_blocks = sorted_blocks(gpu.snapshot());
    const Blocks ref_blocks = ref.block_coords();
    ASSERT_GT(ref_blocks.size(), 200u) << "the scene must fill a few hundred blocks";
    EXPECT_FALSE(has_duplicates(gpu_blocks)) << "frame " << f;
    EXPECT_EQ(stats.allocated_blocks, gpu_blocks.size()) << "frame " << f;
    EXPECT_LE(symmetric_difference(gpu_blocks, ref_blocks), budget(ref_blocks.size()))
        << "frame " << f << ": " << gpu_blocks.size() << " GPU blocks, " << ref_blocks.size()
        << " reference blocks";
    EXPECT_LE(std::abs(double(stats.visible_blocks) - double(allocation.visible.size())),
              budget(allocation.visible.size()))
        << "frame " << f;
    EXPECT_EQ(stats.pool_full + stats.table_full + stats.out_of_range, 0u);
  }
  // After a reset the volume is empty and the next frame allocates as in a new volume.
  ASSERT_TRUE(gpu.volume.reset().ok());
  EXPECT_EQ(gpu.volume.allocated_blocks(), 0u);
  EXPECT_TRUE(gpu.snapshot().blocks.empty());
  const Frame frame = make_frame(scene, orbit_pose(1.0), k, false);
  const IntegrationStats stats = gpu.integrate(frame);
  const Blocks fresh = CpuVolume(config).allocate(frame.depth, k, frame.T_world_camera).visible;
  const Blocks after_reset = sorted_blocks(gpu.snapshot());
  EXPECT_EQ(stats.allocated_blocks, after_reset.size());
  EXPECT_EQ(stats.visible_blocks, after_reset.size());
  EXPECT_LE(symmetric_difference(after_reset, fresh), budget(fresh.size()));
}

TEST_F(GpuTest, VolumeIntegrationMatchesReference) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.max_weight = 3;  // reached below: the cap is exercised
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  const double angles[] = {0.0, 0.3, 0.3, 0.3, 0.3, 0.6};
  for (std::size_t f = 0; f < std::size(angles); ++f) {
    const Frame frame = make_frame(scene, orbit_pose(angles[f]), k, true);
    gpu.integrate(frame);
    ref.fuse(frame.depth, &frame.color, k, frame.T_world_camera);
    if (f == 0 || f + 1 == std::size(angles)) {
      const VoxelDiff diff = compare_voxels(gpu.snapshot(), ref);
      ASSERT_GT(diff.observed, 10000u);
      EXPECT_LE(diff.outliers, budget(diff.observed)) << "after frame " << f << ": " << diff;
    }
  }
  // Without colour the colour stays black on both sides.
  auto gray_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gray_volume.has_value());
  GpuVolume& gray = *gray_volume;
  CpuVolume gray_ref(config);
  const Frame frame = make_frame(scene, orbit_pose(1.0), k, false);
  gray.integrate(frame);
  gray_ref.fuse(frame.depth, nullptr, k, frame.T_world_camera);
  const VoxelDiff diff = compare_voxels(gray.snapshot(), gray_ref);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
}

TEST_F(GpuTest, VolumeRaycastMatchesReferenceOnTheSameVolume) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  for (double angle : {-0.4, 0.0, 0.4})
    gpu.integrate(make_frame(scene, orbit_pose(angle), k, true));
  const CpuVolume ref = CpuVolume::from_host_volume(gpu.snapshot(), config.max_weight);

  // The GPU marches only within the range image of the allocated blocks; the reference marches
  // from near to far. Views: outside the fused blocks, and low over the floor among them, where
  // blocks lie behind the camera and across the near plane (5 cm).
  const Intrinsics view = synth::default_intrinsics(83, 67);
  struct View {
    Eigen::Isometry3d pose;
    float near_depth;
  };
  const View views[] = {
      {orbit_pose(0.15, 1.2, 0.6), 0.3f},
      {look_at(Eigen::Vector3d(0.75, 0.05, 0.09), Eigen::Vector3d(-0.15, 0.1, 0.2)), 0.05f},
  };
  for (const View& v : views) {
    const RaycastImages g = gpu.raycast(view, v.pose, v.near_depth, 4.0f);
    const RaycastImages r = ref.raycast(view, v.pose, v.near_depth, 4.0);
    std::size_t both = 0, disagree = 0, far_vertex = 0, bad_normal = 0, bad_color = 0;
    std::size_t bad_shade = 0;
    for (std::size_t i = 0; i < g.vertices.data.size(); ++i) {
      const bool g_hit = g.vertices.data[i].w() > 0, r_hit = r.vertices.data[i].w() > 0;
      if (g_hit != r_hit) ++disagree;
      if (!g_hit || !r_hit) continue;
      ++both;
      if ((g.vertices.data[i] - r.vertices.data[i]).norm() > 0.001) ++far_vertex;
      if ((g.normals.data[i] - r.normals.data[i]).norm() > 0.01) ++bad_normal;
      for (std::size_t c = 0; c < 3; ++c) {
        if (std::abs(int{g.color.data[3 * i + c]} - int{r.color.data[3 * i + c]}) > 1) {
          ++bad_color;
          break;
        }
      }
      if (std::abs(int{g.shaded.data[3 * i]} - int{r.shaded.data[3 * i]}) > 1) ++bad_shade;
    }
    const std::size_t pixels = g.vertices.data.size();
    ASSERT_GT(both, pixels / 3) << "the view must see the fused objects";
    EXPECT_LE(disagree, pixels / 100) << both << " pixels hit in both";
    EXPECT_EQ(far_vertex, 0u) << "of " << both;
    EXPECT_LE(bad_normal, both / 100) << "of " << both;
    EXPECT_LE(bad_color, both / 100) << "of " << both;
    EXPECT_LE(bad_shade, both / 100) << "of " << both;
  }
}

// Ten known poses around a sphere and a box on a floor, noiseless depth (quantized to 0.2 mm),
// 1 cm voxels; a raycast from an eleventh pose against the exact depth there. Measured on
// lavapipe: median 0.78 mm, 95th percentile 3.7 mm (the tail: grazing floor and silhouettes).
// Normals against the exact surface's: median 3.9 deg, 90th percentile 9.6 deg; the gradient of
// the hit cell's trilinear TSDF alone gave 8.5 / 18.7 deg, too rough for frame-to-model ICP (the
// reconstructor's tracking tests failed on it), hence the bounds of 6 / 15 deg.
TEST_F(GpuTest, VolumeFusedObjectsMatchExactDepth) {
  const Intrinsics k = synth::default_intrinsics(160, 120);
  const VolumeConfig config = small_config();
  const synth::Scene scene = objects_scene();
  synth::SensorModel sensor;
  sensor.depth_noise = false;
  sensor.max_depth = 2.5;
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  constexpr int kPoses = 10;
  for (int f = 0; f < kPoses; ++f) {
    const Eigen::Isometry3d pose =
        orbit_pose(2.0 * std::numbers::pi * f / kPoses, 1.3, 0.6 + 0.05 * (f % 3));
    const DepthImage raw = synth::render_depth(scene, pose, k, sensor, 1);
    Frame frame{FloatImage{k.width, k.height, {}}, {}, pose};
    for (std::uint16_t d : raw.data)
      frame.depth.data.push_back(static_cast<float>(d / raw.depth_scale));
    const IntegrationStats stats = gpu.integrate(frame);
    EXPECT_EQ(stats.pool_full + stats.table_full + stats.out_of_range, 0u);
  }
  // A pose between the fused ones, lower and closer.
  const Eigen::Isometry3d pose = orbit_pose(2.0 * std::numbers::pi * 0.55 / kPoses, 1.1, 0.5);
  const FloatImage exact = exact_depth(scene, pose, k, 2.0);
  const RaycastImages model = gpu.raycast(k, pose, 0.3f, 2.0f);
  std::vector<double> errors, normal_errors;  // metres of depth; degrees between normals
  std::size_t exact_hits = 0;
  for (std::size_t i = 0; i < exact.data.size(); ++i) {
    if (exact.data[i] <= 0.0f) continue;
    ++exact_hits;
    if (model.vertices.data[i].w() <= 0.0f) continue;
    errors.push_back(std::abs(double(model.vertices.data[i].z()) - exact.data[i]));
    const int u = static_cast<int>(i % std::size_t(k.width)), v = static_cast<int>(i / std::size_t(k.width));
    const Eigen::Vector3d ray_c((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    const auto truth = synth::intersect(scene, pose.translation(), pose.linear() * ray_c);
    if (!truth) continue;
    const Eigen::Vector3d normal_world = pose.linear() * model.normals.data[i].head<3>().cast<double>();
    normal_errors.push_back(std::acos(std::clamp(normal_world.dot(truth->normal), -1.0, 1.0)) * 180.0 /
                            std::numbers::pi);
  }
  ASSERT_GT(errors.size(), exact_hits * 8 / 10) << "the raycast must cover most of the view";
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double p95 = errors[errors.size() * 95 / 100];
  EXPECT_LT(median, config.voxel_size) << "95th percentile " << p95;
  EXPECT_LT(p95, config.voxel_size) << "median " << median;
  std::cout << "[volume] raycast vs exact depth over " << errors.size() << " pixels: median "
            << median * 1000 << " mm, 95th percentile " << p95 * 1000 << " mm" << std::endl;
  ASSERT_GT(normal_errors.size(), errors.size() * 9 / 10);
  std::sort(normal_errors.begin(), normal_errors.end());
  const double normal_median = normal_errors[normal_errors.size() / 2];
  const double normal_p90 = normal_errors[normal_errors.size() * 90 / 100];
  std::cout << "[volume] raycast normals vs exact: median " << normal_median << " deg, 90th percentile "
            << normal_p90 << " deg" << std::endl;
  EXPECT_LT(normal_median, 6.0) << "90th percentile " << normal_p90;
  EXPECT_LT(normal_p90, 15.0) << "median " << normal_median;
}

// The voxels of the blocks the GPU stored, as the reference computes them for those blocks only:
// `stored` are the GPU's blocks, `frames` everything fused so far.
CpuVolume reference_on_blocks(const VolumeConfig& config, const Blocks& stored,
                              const std::vector<Frame>& frames, const Intrinsics& k) {
  CpuVolume ref(config);
  for (const Eigen::Vector3i& b : stored) ref.add_block(b);
  for (const Frame& frame : frames) {
    const Blocks visible = reference::visible_blocks(frame.depth, k, frame.T_world_camera,
                                                     config.voxel_size, config.truncation())
                               .visible;
    ref.integrate(frame.depth, frame.color.data.empty() ? nullptr : &frame.color, k,
                  frame.T_world_camera, visible);
  }
  return ref;
}

// How many blocks share their home slot (the GPU's hash) with another block.
std::size_t home_slot_collisions(const Blocks& blocks, std::uint32_t hash_slots) {
  std::vector<int> load(hash_slots, 0);
  for (const Eigen::Vector3i& b : blocks) {
    const std::uint32_t h = (static_cast<std::uint32_t>(b.x()) * 73856093u) ^
                            (static_cast<std::uint32_t>(b.y()) * 19349669u) ^
                            (static_cast<std::uint32_t>(b.z()) * 83492791u);
    ++load[h & (hash_slots - 1)];
  }
  std::size_t colliding = 0;
  for (int n : load) colliding += n > 1 ? static_cast<std::size_t>(n) : 0;
  return colliding;
}

// A small sphere alone: a few dozen blocks.
synth::Scene small_sphere_scene() {
  synth::Scene scene;
  synth::Sphere sphere;
  sphere.center = Eigen::Vector3d(0.1, 0.0, 0.2);
  sphere.radius = 0.16;
  scene.spheres.push_back(sphere);
  return scene;
}

TEST_F(GpuTest, VolumeLongProbeChainsStillFindEveryBlock) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = config.hash_slots = 64;  // every block collides with its neighbours
  const synth::Scene scene = small_sphere_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  for (double angle : {0.0, 0.1}) {
    const Frame frame = make_frame(scene, orbit_pose(angle), k, true);
    const IntegrationStats stats = gpu.integrate(frame);
    ref.fuse(frame.depth, &frame.color, k, frame.T_world_camera);
    EXPECT_EQ(stats.pool_full + stats.table_full + stats.out_of_range, 0u);
    EXPECT_EQ(stats.allocated_blocks, ref.block_count());
  }
  const Blocks ref_blocks = ref.block_coords();
  ASSERT_GT(ref_blocks.size(), 40u) << "the table must be mostly full";
  ASSERT_LE(ref_blocks.size(), 64u) << "the blocks must fit";
  EXPECT_GT(home_slot_collisions(ref_blocks, config.hash_slots), ref_blocks.size() / 3);
  const HostVolume host = gpu.snapshot();
  EXPECT_EQ(host.blocks.size(), gpu.volume.allocated_blocks());
  EXPECT_EQ(symmetric_difference(sorted_blocks(host), ref_blocks), 0u);
  const VoxelDiff diff = compare_voxels(host, ref);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
  // Lookups through the long chains: the raycast finds the surface.
  const RaycastImages view = gpu.raycast(k, orbit_pose(0.05), 0.3f, 3.0f);
  const std::size_t hits =
      static_cast<std::size_t>(std::count_if(view.vertices.data.begin(), view.vertices.data.end(),
                                             [](const Eigen::Vector4f& v) { return v.w() > 0; }));
  EXPECT_GT(hits, 100u);
}

// Checks a volume whose pool or table overflowed: capacity respected, the stored blocks are
// blocks the frames touched, and each holds what the reference computes for it.
void expect_stored_blocks_correct(GpuVolume& gpu, const VolumeConfig& config,
                                  const std::vector<Frame>& frames, const Intrinsics& k) {
  const HostVolume host = gpu.snapshot();
  const Blocks stored = sorted_blocks(host);
  EXPECT_EQ(stored.size(), config.block_capacity);
  EXPECT_FALSE(has_duplicates(stored));
  CpuVolume all(config);
  for (const Frame& frame : frames) all.allocate(frame.depth, k, frame.T_world_camera);
  Blocks outside;
  const Blocks touched = all.block_coords();
  std::set_difference(stored.begin(), stored.end(), touched.begin(), touched.end(),
                      std::back_inserter(outside), reference::block_less);
  EXPECT_LE(outside.size(), 1u) << "stored blocks that no frame touched";
  const VoxelDiff diff = compare_voxels(host, reference_on_blocks(config, stored, frames, k));
  ASSERT_GT(diff.observed, 5000u);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
}

// A frame's report: of the blocks it touched (the reference's visible set), those with storage
// are fused (visible_blocks) and the others counted in pool_full, up to the allocation budget.
void expect_touched_blocks_reported(const IntegrationStats& stats, GpuVolume& gpu,
                                    const VolumeConfig& config, const Frame& frame,
                                    const Intrinsics& k) {
  const Blocks touched = reference::visible_blocks(frame.depth, k, frame.T_world_camera,
                                                   config.voxel_size, config.truncation())
                             .visible;
  const Blocks stored = sorted_blocks(gpu.snapshot());
  Blocks fused;
  std::set_intersection(touched.begin(), touched.end(), stored.begin(), stored.end(),
                        std::back_inserter(fused), reference::block_less);
  EXPECT_NEAR(double(stats.visible_blocks), double(fused.size()), budget(touched.size()));
  EXPECT_NEAR(double(stats.pool_full), double(touched.size() - fused.size()),
              budget(touched.size()));
}

TEST_F(GpuTest, VolumeFullPoolReportsAndKeepsStoredBlocksCorrect) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = 64;  // the objects need hundreds
  config.hash_slots = 16384;   // keys of blocks refused storage stay in the table: room for all
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  std::vector<Frame> frames;
  // The same view twice, then another. Blocks refused storage keep their key in the table (with
  // no pool index); seen again they are refused again, and must not take the place of blocks
  // that have storage.
  for (double angle : {0.0, 0.0, 0.2}) {
    frames.push_back(make_frame(scene, orbit_pose(angle), k, true));
    const IntegrationStats stats = gpu.integrate(frames.back());
    EXPECT_EQ(stats.table_full, 0u);
    EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
    expect_touched_blocks_reported(stats, gpu, config, frames.back(), k);
    expect_stored_blocks_correct(gpu, config, frames, k);
  }
}

// The frame that fills the pool: thousands of insertions race for 256 pool blocks. Every stored
// block was touched by this first frame, so all of them must be fused, none pushed off the
// visible list by a refused block, and every refused block reported.
TEST_F(GpuTest, VolumeFrameThatFillsThePoolFusesEveryStoredBlock) {
  const Intrinsics k = synth::default_intrinsics(320, 240);
  VolumeConfig config = small_config();
  config.block_capacity = 256;
  const synth::Scene scene = objects_scene();
  for (double angle : {0.0, 0.7, 1.4}) {
    auto gpu_volume = GpuVolume::create(context_, config, k);
    ASSERT_TRUE(gpu_volume.has_value());
    GpuVolume& gpu = *gpu_volume;
    const std::vector<Frame> frames{make_frame(scene, orbit_pose(angle), k, true)};
    const IntegrationStats stats = gpu.integrate(frames.back());
    EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
    EXPECT_EQ(stats.visible_blocks, config.block_capacity) << "angle " << angle;
    EXPECT_GT(stats.pool_full, config.block_capacity) << "the frame needs several times the pool";
    expect_touched_blocks_reported(stats, gpu, config, frames.back(), k);
    expect_stored_blocks_correct(gpu, config, frames, k);
  }
}

TEST_F(GpuTest, VolumeFullTableReportsWithoutHanging) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  VolumeConfig config = small_config();
  config.block_capacity = config.hash_slots = 64;  // every slot ends up used
  const synth::Scene scene = objects_scene();
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  std::vector<Frame> frames;
  for (double angle : {0.0, 0.3}) {
    frames.push_back(make_frame(scene, orbit_pose(angle), k, false));
    const IntegrationStats stats = gpu.integrate(frames.back());
    EXPECT_GT(stats.table_full, 0u);
    EXPECT_EQ(stats.pool_full, 0u) << "as many slots as pool blocks: the pool cannot overflow";
    EXPECT_EQ(stats.allocated_blocks, config.block_capacity);
    expect_stored_blocks_correct(gpu, config, frames, k);
  }
  // Lookups of absent blocks probe the whole full table and give up.
  const RaycastImages view = gpu.raycast(k, orbit_pose(0.1), 0.3f, 3.0f);
  EXPECT_EQ(view.vertices.data.size(), static_cast<std::size_t>(k.width * k.height));
}

TEST_F(GpuTest, VolumeOutOfRangeBlocksAreCountedAndNotFused) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  synth::Scene scene = objects_scene();
  // A wall across the edge of the key range: blocks x = 1023 (in) and 1024 (out), at 81.9 m.
  synth::Plane wall;
  wall.normal = Eigen::Vector3d::UnitX();
  wall.offset = 81.9;
  scene.planes.push_back(wall);
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  const Frame home = make_frame(scene, orbit_pose(0.0), k, true);
  gpu.integrate(home);
  ref.fuse(home.depth, &home.color, k, home.T_world_camera);
  const HostVolume before = gpu.snapshot();

  // 100 km away, looking at the same objects moved with it: every block is out of range.
  Eigen::Isometry3d far_pose = orbit_pose(0.0);
  far_pose.translation() += Eigen::Vector3d(1.0e5, 0.0, 0.0);
  const Frame far_frame{home.depth, home.color, far_pose};
  const IntegrationStats far_stats = gpu.integrate(far_frame);
  EXPECT_GT(far_stats.out_of_range, 0u);
  EXPECT_EQ(far_stats.visible_blocks, 0u);
  EXPECT_EQ(far_stats.allocated_blocks, before.blocks.size());
  const VoxelDiff unchanged =
      compare_voxels(gpu.snapshot(), CpuVolume::from_host_volume(before, 64));
  EXPECT_EQ(unchanged.outliers, 0u) << unchanged;
  EXPECT_EQ(ref.fuse(far_frame.depth, &far_frame.color, k, far_pose).visible.size(), 0u);

  // Half in, half out of range: the in-range half is fused like the reference does.
  const Frame edge = make_frame(
      scene, look_at(Eigen::Vector3d(80.9, 0.05, 0.1), Eigen::Vector3d(81.9, 0.05, 0.1)), k, true);
  const IntegrationStats edge_stats = gpu.integrate(edge);
  const auto edge_ref = ref.fuse(edge.depth, &edge.color, k, edge.T_world_camera);
  EXPECT_GT(edge_ref.out_of_range, 0u);
  EXPECT_GT(edge_ref.visible.size(), 0u);
  EXPECT_NEAR(double(edge_stats.out_of_range), double(edge_ref.out_of_range),
              budget(edge_ref.out_of_range));
  EXPECT_EQ(edge_stats.pool_full + edge_stats.table_full, 0u);
  const VoxelDiff diff = compare_voxels(gpu.snapshot(), ref);
  EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
}

// The last block of the key range, (1023, 1023, 511), would pack to the bits of the empty-slot
// marker, so it counts as out of range. Before it did, every ray through it took a new pool
// block (none of them findable): allocated_blocks grew past the blocks in the table.
TEST_F(GpuTest, VolumeLastKeyOfTheRangeIsNotAllocated) {
  const Intrinsics k = synth::default_intrinsics(97, 61);
  const VolumeConfig config = small_config();
  const double edge = 1024 * kBlockSide * config.voxel_size;   // 81.92 m: first x, y out
  const double edge_z = 512 * kBlockSide * config.voxel_size;  // 40.96 m: first z out
  synth::Scene scene;
  synth::Plane wall;
  wall.normal = Eigen::Vector3d::UnitX();
  wall.offset = edge - 0.03;
  scene.planes.push_back(wall);
  // A point of the wall inside block (1023, 1023, 511), seen by the centre pixel.
  const Eigen::Vector3d corner(edge - 0.03, edge - 0.04, edge_z - 0.04);
  const Eigen::Vector3i last_key(1023, 1023, 511);
  auto gpu_volume = GpuVolume::create(context_, config, k);
  ASSERT_TRUE(gpu_volume.has_value());
  GpuVolume& gpu = *gpu_volume;
  CpuVolume ref(config);
  for (double dx : {1.0, 0.8}) {
    const Frame frame =
        make_frame(scene, look_at(corner - Eigen::Vector3d(dx, 0.0, 0.0), corner), k, true);
    ASSERT_GT(frame.depth.at(k.width / 2, k.height / 2), 0.0f);
    const IntegrationStats stats = gpu.integrate(frame);
    ref.fuse(frame.depth, &frame.color, k, frame.T_world_camera);
    ASSERT_TRUE(ref.contains(Eigen::Vector3i(1023, 1022, 511)));
    ASSERT_TRUE(ref.contains(Eigen::Vector3i(1023, 1023, 510)));
    EXPECT_FALSE(ref.contains(last_key));
    EXPECT_GT(stats.out_of_range, 0u);
    EXPECT_EQ(stats.allocated_blocks, ref.block_count());
    const HostVolume host = gpu.snapshot();
    EXPECT_EQ(host.blocks.size(), stats.allocated_blocks);
    EXPECT_EQ(symmetric_difference(sorted_blocks(host), ref.block_coords()), 0u);
    const VoxelDiff diff = compare_voxels(host, ref);
    EXPECT_LE(diff.outliers, budget(diff.observed)) << diff;
  }
}

TEST_F(GpuTest, VolumeMemoryIsEightBytesPerVoxel) {
  VolumeConfig config = small_config();
  config.block_capacity = 96;
  config.hash_slots = 256;
  auto fusion = TsdfFusion::create(config, PreprocessConfig{}, synth::default_intrinsics(97, 61));
  ASSERT_TRUE(fusion.ok()) << fusion.error().describe();
  // Pool: two 32-bit words per voxel and the hash slot of each block. Table: key, value and
  // visibility stamp per slot. Visible list: one entry per slot.
  const std::uint64_t pool = std::uint64_t{config.block_capacity} * (kBlockVoxels * 8 + 4);
  const std::uint64_t table = std::uint64_t{config.hash_slots} * 3 * 4;
  const std::uint64_t visible = std::uint64_t{config.hash_slots} * 4;
  EXPECT_EQ(fusion->memory_bytes(), pool + table + visible);
  EXPECT_EQ(fusion->validation_error_count(), 0u);
}

}  // namespace
}  // namespace imufusion
