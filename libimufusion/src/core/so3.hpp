#pragma once
// Rotation helpers on SO(3): the cross-product matrix, Exp and Log of rotation vectors, and the
// right Jacobian. Pure C++.

#include <Eigen/Core>

namespace imufusion {

/// [v]x: the cross-product matrix, [v]x w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
/// Exp of a rotation vector (rad).
Eigen::Matrix3d exp_so3(const Eigen::Vector3d& phi);
/// Log of a rotation: the rotation vector (rad), angle in [0, pi].
Eigen::Vector3d log_so3(const Eigen::Matrix3d& R);
/// Right Jacobian of SO(3): Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d right_jacobian_so3(const Eigen::Vector3d& phi);

}  // namespace imufusion
