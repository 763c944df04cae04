#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace loopd {

/// @brief An odometry pose T_world_sensor at a time.
struct StampedPose {
  std::int64_t utime = 0;  ///< [us]
  Eigen::Isometry3d T_world_sensor = Eigen::Isometry3d::Identity();
  double residual = 0.0;  ///< scan-matching residual of the step ending here [m]; 0 when unknown
};

/// @brief Interpolates between two poses: translation linearly, rotation by slerp. alpha in [0, 1].
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha);

/// @brief Interpolates along the screw motion from a to b: a * Exp(alpha * Log(a^-1 b)) on SE(3), i.e. at a constant
///        velocity in the moving frame (a vehicle on a circular arc at a constant speed and yaw rate stays on its arc;
///        interpolate() would cut the chord). Any alpha: outside [0, 1] it continues the same motion.
Eigen::Isometry3d interpolate_screw(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha);

/// @brief Rotation angle of an isometry [rad].
double rotation_angle(const Eigen::Isometry3d& T);

/// @brief Builds an isometry from a position and a (w, x, y, z) quaternion; the quaternion is normalised.
Eigen::Isometry3d make_isometry(const double position[3], const double orientation_wxyz[4]);

/// @brief 4x4 row-major copy of an isometry.
void to_row_major(const Eigen::Isometry3d& T, double out[16]);
/// @brief Isometry from 4x4 row-major numbers (the rotation is re-orthonormalised).
Eigen::Isometry3d from_row_major(const double in[16]);

/// @brief Isometry from yaw/pitch/roll [rad] and translation [m].
Eigen::Isometry3d make_isometry(double x, double y, double z, double yaw, double pitch = 0.0, double roll = 0.0);

}  // namespace loopd
