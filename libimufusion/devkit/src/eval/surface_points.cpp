// Ground-truth surface samples: the points a depth camera at the true poses could have seen.

#include <cmath>
#include <numbers>
#include <unordered_set>

#include "imufusion/mesh_eval.hpp"
#include "imufusion/synth.hpp"
#include "mesh/lattice_key.hpp"

namespace imufusion {

std::vector<Eigen::Vector3d> observed_surface_points(const synth::Scene& scene,
                                                     const Trajectory& poses,
                                                     const Intrinsics& intrinsics,
                                                     const SurfaceSampleOptions& options) {
  std::vector<Eigen::Vector3d> points;
  if (options.frame_step < 1 || options.pixel_step < 1 || !(options.cell_size > 0.0) ||
      !(intrinsics.fx > 0.0) || !(intrinsics.fy > 0.0)) {
    return points;
  }
  const double min_cos = std::cos(options.max_incidence_deg * std::numbers::pi / 180.0);
  std::unordered_set<std::uint64_t> occupied;
  const int half = options.pixel_step / 2;
  for (std::size_t f = 0; f < poses.size(); f += static_cast<std::size_t>(options.frame_step)) {
    const Eigen::Isometry3d& T_world_camera = poses[f].T_world_camera;
    const Eigen::Vector3d origin = T_world_camera.translation();
    for (int v = half; v < intrinsics.height; v += options.pixel_step) {
      for (int u = half; u < intrinsics.width; u += options.pixel_step) {
        // A camera ray with unit z: the hit's ray parameter is its depth along the optical axis.
        const Eigen::Vector3d ray_camera((u - intrinsics.cx) / intrinsics.fx,
                                         (v - intrinsics.cy) / intrinsics.fy, 1.0);
        const Eigen::Vector3d ray = T_world_camera.linear() * ray_camera;
        const auto hit = synth::intersect(scene, origin, ray);
        if (!hit || hit->t < options.min_depth || hit->t > options.max_depth) continue;
        if (std::abs(hit->normal.dot(ray)) < min_cos * ray.norm()) continue;
        const Eigen::Vector3d cell =
            (hit->point / options.cell_size).array().floor().cwiseMax(-1e9).cwiseMin(1e9);
        const Eigen::Vector3i c = cell.cast<int>();
        const std::uint64_t key = mesh::pack20(c);
        if (occupied.insert(key).second) points.push_back(hit->point);
      }
    }
  }
  return points;
}

}  // namespace imufusion
