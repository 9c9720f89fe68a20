#pragma once
// Per-render acceleration data for a Scene: bounding spheres for the early-out test.

#include <optional>
#include <vector>

#include "imufusion/synth.hpp"

namespace imufusion::synth {

struct Bound {
  Eigen::Vector3d center;
  double radius;
};

/// A scene plus bounding spheres of its boxes and cylinders; borrows the scene.
struct PreparedScene {
  const Scene* scene = nullptr;
  std::vector<Bound> box_bounds;
  std::vector<Eigen::Matrix3d> box_rotations;  // R_world_box
  std::vector<Bound> cylinder_bounds;
};

PreparedScene prepare(const Scene& scene);

std::optional<RayHit> intersect(const PreparedScene& prepared, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& direction);

}  // namespace imufusion::synth
