#include "core/so3.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace imufusion {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(),  //
      v.z(), 0, -v.x(),   //
      -v.y(), v.x(), 0;
  return S;
}

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity() + skew(phi);
  return Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix();
}

Eigen::Vector3d log_so3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d right_jacobian_so3(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  const Eigen::Matrix3d S = skew(phi);
  if (angle < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * S;
  const double a2 = angle * angle;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(angle)) / a2 * S +
         (angle - std::sin(angle)) / (a2 * angle) * S * S;
}

}  // namespace imufusion
