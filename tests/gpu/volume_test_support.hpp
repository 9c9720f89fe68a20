#pragma once
// Shared by the GPU volume tests (volume_test.cpp, volume_limits_test.cpp): scenes and poses, the
// GPU volume under test with its CPU reference, and the comparisons with their tolerances (see
// volume_test.cpp's header comment).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <numbers>
#include <optional>
#include <vector>

#include "gpu/volume.hpp"
#include "gpu_test_env.hpp"
#include "imufusion/fusion.hpp"
#include "imufusion/synth.hpp"
#include "reference/volume_reference.hpp"
#include "vk/buffer.hpp"

namespace imufusion::volume_test {

using reference::CpuVolume;
using test::GpuTest;
using Blocks = std::vector<Eigen::Vector3i>;

inline constexpr double kBudget = 0.005;  // outlier fraction allowed (see the header)

inline double budget(std::size_t count) { return kBudget * static_cast<double>(count); }

inline Eigen::Isometry3d look_at(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - position).normalized();                // optical axis
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();  // right (z up)
  const Eigen::Vector3d y = z.cross(x);                                      // down
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() << x, y, z;
  T.translation() = position;
  return T;
}

// A camera on a circle around the objects, `angle` radians, looking at their middle.
inline Eigen::Isometry3d orbit_pose(double angle, double radius = 1.3, double height = 0.75) {
  const Eigen::Vector3d target(0.1, 0.0, 0.2);
  return look_at(
      target + Eigen::Vector3d(radius * std::cos(angle), radius * std::sin(angle), height), target);
}

// A sphere and a yawed box on a checkered floor (world z up, metres).
inline synth::Scene objects_scene() {
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

inline Blocks sorted_blocks(const HostVolume& host) {
  Blocks blocks;
  for (const VolumeBlock& b : host.blocks) blocks.push_back(b.coord);
  std::sort(blocks.begin(), blocks.end(), reference::block_less);
  return blocks;
}

inline std::size_t symmetric_difference(const Blocks& a, const Blocks& b) {
  Blocks out;
  std::set_symmetric_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out),
                                reference::block_less);
  return out.size();
}

inline bool has_duplicates(Blocks blocks) {
  return std::adjacent_find(blocks.begin(), blocks.end()) != blocks.end();
}

struct VoxelDiff {
  std::size_t observed = 0;                                 // voxels observed in either volume
  std::size_t status = 0, tsdf = 0, weight = 0, color = 0;  // kinds of disagreement
  std::size_t outliers = 0;                                 // voxels with any disagreement
};

inline std::ostream& operator<<(std::ostream& os, const VoxelDiff& d) {
  return os << d.outliers << " outliers of " << d.observed << " observed voxels (status "
            << d.status << ", tsdf " << d.tsdf << ", weight " << d.weight << ", colour " << d.color
            << ")";
}

// Voxel-by-voxel comparison over the union of both volumes' blocks.
inline VoxelDiff compare_voxels(const HostVolume& gpu, const CpuVolume& ref) {
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

inline VolumeConfig small_config() {
  VolumeConfig config;
  config.voxel_size = 0.01f;
  config.truncation_voxels = 4.0f;
  config.max_weight = 64;
  config.block_capacity = 8192;
  config.hash_slots = 16384;
  return config;
}

// The voxels of the blocks the GPU stored, as the reference computes them for those blocks only:
// `stored` are the GPU's blocks, `frames` everything fused so far.
inline CpuVolume reference_on_blocks(const VolumeConfig& config, const Blocks& stored,
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

}  // namespace imufusion::volume_test
