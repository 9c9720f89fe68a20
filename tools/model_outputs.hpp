#pragma once
// What imufusion-scan and imufusion-fuse share: fusion at known poses (a TUM trajectory, e.g.
// ground truth or external tracking) and the outputs of the fused model, written into the
// staging directory of an output set (io/output_set.hpp): mesh.glb, mesh.ply, preview.png (the
// model from the last pose) and overview.png (the whole model from outside, with the camera's
// path: tracked and lost stretches in two colours). Both pictures show the fused colour where
// the scan has colour, shading elsewhere.

#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imufusion/image_io.hpp"
#include "imufusion/mesh.hpp"
#include "imufusion/reconstructor.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/trajectory.hpp"
#include "io/output_set.hpp"
#include "overview_image.hpp"
#include "overview_pose.hpp"

namespace imufusion::tools {

/// The files write_model_outputs() writes.
inline constexpr const char* kModelOutputs[] = {"mesh.glb", "mesh.ply", "preview.png",
                                                "overview.png"};

/// Fuses `frame` at its pose in `known` (the nearest within 20 ms, find_pose); nullopt when
/// `known` has no pose for it.
inline Result<std::optional<FrameResult>> fuse_at_known_pose(Reconstructor& rec,
                                                             const Trajectory& known,
                                                             const Frame& frame) {
  const StampedPose* pose = find_pose(known, frame.timestamp);
  if (pose == nullptr) return std::optional<FrameResult>{};
  auto result =
      rec.fuse_with_pose(frame.timestamp, frame.depth, frame.color ? &*frame.color : nullptr,
                         pose->T_world_camera, frame.imu);
  if (!result) return result.error();
  return std::optional<FrameResult>(std::move(*result));
}

/// The overview image's size (pixels), raycast at twice this and averaged down (anti-aliasing).
inline constexpr int kOverviewWidth = 640, kOverviewHeight = 480;

/// The trajectory as a path (PathPoint), each pose tracked unless `lost_at` (seconds, ascending)
/// holds its timestamp (within 1 microsecond).
inline std::vector<PathPoint> path_of(const Trajectory& trajectory,
                                      const std::vector<double>& lost_at = {}) {
  std::vector<PathPoint> path;
  path.reserve(trajectory.size());
  auto lost = lost_at.begin();
  for (const StampedPose& pose : trajectory) {
    while (lost != lost_at.end() && *lost < pose.timestamp - 1e-6) ++lost;
    const bool is_lost = lost != lost_at.end() && std::abs(*lost - pose.timestamp) <= 1e-6;
    path.push_back({pose.T_world_camera.translation(), !is_lost});
  }
  return path;
}

/// The model raycast from `T_world_camera` with intrinsics `k` at twice their size, as a
/// coloured, shaded picture of `k`'s size (model_picture, downsample_2x).
inline Result<ColorImage> model_view(Reconstructor& rec, const Eigen::Isometry3d& T_world_camera,
                                     const Intrinsics& k,
                                     std::optional<std::pair<float, float>> depth_range) {
  Intrinsics k2 = k;
  k2.fx *= 2;
  k2.fy *= 2;
  k2.cx = 2 * k.cx + 0.5;  // pixel u is the 2x2 block 2u, 2u + 1: x2 = 2 x + 0.5
  k2.cy = 2 * k.cy + 0.5;
  k2.width *= 2;
  k2.height *= 2;
  auto images = rec.raycast(T_world_camera, k2, depth_range);
  if (!images) return images.error();
  return downsample_2x(model_picture(*images));
}

/// The whole model from outside (overview_pose over the mesh and `path`), with `path` drawn on.
inline Result<ColorImage> overview_picture(Reconstructor& rec, const Mesh& mesh,
                                           const std::vector<PathPoint>& path) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(mesh.vertices.size() + path.size());
  for (const Eigen::Vector3f& v : mesh.vertices) points.push_back(v.cast<double>());
  for (const PathPoint& p : path) points.push_back(p.position);
  const Intrinsics k = overview_intrinsics(kOverviewWidth, kOverviewHeight);
  const Eigen::Isometry3d T = overview_pose(points, rec.trajectory().front().T_world_camera, k);
  // The rays run over the points' depths only (metres, with a 5% margin).
  const Eigen::Isometry3d T_camera_world = T.inverse();
  float near = 1e30f, far = 0;
  for (const Eigen::Vector3d& p : points) {
    const auto z = static_cast<float>((T_camera_world * p).z());
    near = std::min(near, z);
    far = std::max(far, z);
  }
  const float margin = 0.05f * (far - near) + 0.05f;
  auto picture = model_view(rec, T, k, std::pair{std::max(0.01f, near - margin), far + margin});
  if (!picture) return picture.error();
  draw_path(*picture, k, T, path);
  return picture;
}

/// Writes `mesh` (the model's, with triangles) as mesh.glb and mesh.ply, the model seen from the
/// last pose of the trajectory (preview.png) and the whole model from outside with the camera's
/// `path` on it (overview.png). Returns the wall time of the two pictures, ms.
inline Result<double> write_model_outputs(const io::OutputSet& set, Reconstructor& rec,
                                          const Mesh& mesh, const std::vector<PathPoint>& path) {
  IMUFUSION_RETURN_IF_ERROR(write_glb(set.staged("mesh.glb"), mesh));
  IMUFUSION_RETURN_IF_ERROR(write_ply(set.staged("mesh.ply"), mesh));
  const auto start = std::chrono::steady_clock::now();
  auto preview = model_view(rec, rec.trajectory().back().T_world_camera, rec.config().intrinsics,
                            std::nullopt);
  if (!preview) return preview.error();
  IMUFUSION_RETURN_IF_ERROR(write_color_png(set.staged("preview.png"), *preview));
  auto overview = overview_picture(rec, mesh, path);
  if (!overview) return overview.error();
  IMUFUSION_RETURN_IF_ERROR(write_color_png(set.staged("overview.png"), *overview));
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace imufusion::tools
