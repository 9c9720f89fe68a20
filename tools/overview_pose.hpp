#pragma once
// A viewpoint that shows the whole fused model, for overview images.

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "imufusion/types.hpp"

namespace imufusion::tools {

// The intrinsics of the overview image: `width` x `height` pixels, 50 deg vertical field of view,
// square pixels, centred principal point.
inline Intrinsics overview_intrinsics(int width, int height) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fy = k.fx = 0.5 * height / std::tan(25.0 * M_PI / 180.0);
  k.cx = 0.5 * width;
  k.cy = 0.5 * height;
  return k;
}

// A camera behind and above the first pose (`first`, camera to world), looking down at the
// points (world, metres: the mesh's vertices and the camera's path), placed so that every point
// lies inside `k`'s image, within `fill` (0..1) of its half width and height from the centre:
// the model fills the image. The identity when `points` is empty.
inline Eigen::Isometry3d overview_pose(const std::vector<Eigen::Vector3d>& points,
                                       const Eigen::Isometry3d& first, const Intrinsics& k,
                                       double fill = 0.94) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (points.empty()) return T;
  const Eigen::Vector3d up = -first.linear().col(1);  // camera y points down
  const Eigen::Vector3d back = -first.linear().col(2);
  const Eigen::Vector3d z = -(0.8 * back + 0.6 * up).normalized();  // the viewing direction
  Eigen::Matrix3d R;
  R.col(0) = z.cross(up).normalized();  // image x: right (y = down, x = y cross z)
  R.col(2) = z;
  R.col(1) = z.cross(R.col(0));  // image y: down
  // In the camera's axes (q = R^T p) the eye e sees every point when, per image axis with
  // half-fov tangent t, e.x + t e.z <= q.x + t q.z and t e.z - e.x <= t q.z - q.x. With
  // a = min(q.x + t q.z) and c = min(t q.z - q.x) the nearest eye has e.z = (a + c) / 2t at
  // e.x = (a - c) / 2; the nearer of the two axes' limits binds, the other keeps its centre.
  const double tan_x = fill * std::min(k.cx, k.width - k.cx) / k.fx;
  const double tan_y = fill * std::min(k.cy, k.height - k.cy) / k.fy;
  double ax = 1e300, cx = 1e300, ay = 1e300, cy = 1e300;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d q = R.transpose() * p;
    ax = std::min(ax, q.x() + tan_x * q.z());
    cx = std::min(cx, tan_x * q.z() - q.x());
    ay = std::min(ay, q.y() + tan_y * q.z());
    cy = std::min(cy, tan_y * q.z() - q.y());
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  double eye_z = std::min((ax + cx) / (2 * tan_x), (ay + cy) / (2 * tan_y));
  eye_z -= 0.01 * (hi - lo).norm() + 1e-3;  // keep the nearest points off the near plane
  T.linear() = R;
  T.translation() = R * Eigen::Vector3d(0.5 * (ax - cx), 0.5 * (ay - cy), eye_z);
  return T;
}

}  // namespace imufusion::tools
