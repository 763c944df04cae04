#pragma once
/// @file The one order of a 6x6 pose information matrix in loopd.
#include <Eigen/Core>

namespace loopd {

/// @brief Information (inverse covariance) of a relative pose T_a_b, everywhere in loopd (verification results, loop
/// constraints, odometry steps, the pose graph, the map store): order (tx, ty, tz [m], rx, ry, rz [rad]), a right
/// perturbation T_a_b * Exp(delta) in the frame of b. All zero = unknown.
using Information6d = Eigen::Matrix<double, 6, 6>;

/// @brief A 6x6 matrix in rotation-first order (rx, ry, rz, tx, ty, tz), as GICP's Gauss-Newton Hessian is solved,
/// in loopd's translation-first order: the one place the blocks are swapped.
inline Information6d information_from_rotation_first(const Eigen::Matrix<double, 6, 6>& rotation_first) {
  Information6d out;
  out.topLeftCorner<3, 3>() = rotation_first.bottomRightCorner<3, 3>();
  out.bottomRightCorner<3, 3>() = rotation_first.topLeftCorner<3, 3>();
  out.topRightCorner<3, 3>() = rotation_first.bottomLeftCorner<3, 3>();
  out.bottomLeftCorner<3, 3>() = rotation_first.topRightCorner<3, 3>();
  return out;
}

}  // namespace loopd
