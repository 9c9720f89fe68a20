#pragma once
// A viewpoint that shows the whole fused volume, for overview images.

#include <Eigen/Geometry>
#include <cmath>

#include "imufusion/types.hpp"
#include "imufusion/volume.hpp"

namespace imufusion::tools {

// A camera behind and above the first pose, looking at the centre of the allocated blocks, far
// enough back to see all of them.
inline Eigen::Isometry3d overview_pose(const HostVolume& volume, const Eigen::Isometry3d& first,
                                       const Intrinsics& k) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  const double block = volume.voxel_size * kBlockSide;
  for (const VolumeBlock& b : volume.blocks) {
    lo = lo.cwiseMin(b.coord.cast<double>() * block);
    hi = hi.cwiseMax((b.coord.cast<double>() + Eigen::Vector3d::Ones()) * block);
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = 0.5 * (hi - lo).norm();
  const double half_fov = std::atan(0.5 * k.height / k.fy);
  const double distance = radius / std::sin(half_fov);
  const Eigen::Vector3d up = -first.linear().col(1);  // camera y points down
  const Eigen::Vector3d back = -first.linear().col(2);
  const Eigen::Vector3d eye = centre + distance * (0.8 * back + 0.6 * up).normalized();
  const Eigen::Vector3d z = (centre - eye).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized().eval() * -1.0;
  Eigen::Matrix3d R;
  R.col(0) = -x;
  R.col(2) = z;
  R.col(1) = z.cross(R.col(0));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = eye;
  return T;
}

}  // namespace imufusion::tools
