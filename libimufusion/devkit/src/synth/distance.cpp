// Exact unsigned distances to the analytic primitives: the absolute value of each primitive's
// exact signed distance function (Quilez's box and capped-cylinder forms).

#include <algorithm>
#include <cmath>
#include <limits>

#include "imufusion/synth.hpp"

namespace imufusion::synth {
namespace {

// Signed distance to an axis-aligned box with half extents `h` centred at the origin.
double box_sdf(const Eigen::Vector3d& p, const Eigen::Vector3d& h) {
  const Eigen::Vector3d q = p.cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

}  // namespace

double distance_to_surface(const Scene& scene, const Eigen::Vector3d& point) {
  double best = std::numeric_limits<double>::infinity();
  if (scene.room) {
    const Eigen::Vector3d centre = 0.5 * (scene.room->min + scene.room->max);
    const Eigen::Vector3d half = 0.5 * (scene.room->max - scene.room->min);
    best = std::min(best, std::abs(box_sdf(point - centre, half)));
  }
  for (const Box& box : scene.boxes) {
    // Into the box frame: undo the yaw about world z.
    const Eigen::Vector3d local =
        Eigen::AngleAxisd(-box.yaw, Eigen::Vector3d::UnitZ()) * (point - box.center);
    best = std::min(best, std::abs(box_sdf(local, box.half_extents)));
  }
  for (const Cylinder& cylinder : scene.cylinders) {
    const double radial = (point.head<2>() - cylinder.center_xy).norm() - cylinder.radius;
    const double half_height = 0.5 * (cylinder.z_max - cylinder.z_min);
    const double axial =
        std::abs(point.z() - 0.5 * (cylinder.z_min + cylinder.z_max)) - half_height;
    const double outside = std::hypot(std::max(radial, 0.0), std::max(axial, 0.0));
    best = std::min(best, std::abs(outside + std::min(std::max(radial, axial), 0.0)));
  }
  for (const Sphere& sphere : scene.spheres) {
    best = std::min(best, std::abs((point - sphere.center).norm() - sphere.radius));
  }
  for (const Plane& plane : scene.planes) {
    best = std::min(best, std::abs(plane.normal.dot(point) - plane.offset));
  }
  return best;
}

}  // namespace imufusion::synth
