#pragma once
/// @file Gyro samples and the rotation they integrate to.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief One gyro sample: the turn rate at utime, in the IMU's frame.
struct ImuSample {
  std::int64_t utime = 0;                                      ///< [us]
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< [rad/s] about the IMU's axes
};

/// @brief The sensor's rotation at every sample time, relative to the first (identity): R_{k+1} = R_k Exp(w dt) with w
///        sample k+1's rate turned into the sensor frame (R_sensor_imu w_imu), taken as the mean rate over the period
///        before it (an integrating gyro's output; for an instantaneous rate at 100 Hz and more the difference to the
///        trapezoid rule is of second order in the period). The positions are dead-reckoned at a constant velocity in
///        the sensor's frame (`body_velocity` [m/s]: a vehicle's speed holds over a sweep, its turn rate need not), so
///        the path curves as the sensor turns. Samples must be sorted by strictly increasing utime; a gap longer than
///        max_gap [s] ends the track there.
std::vector<StampedPose> integrate_gyro(const std::vector<ImuSample>& samples, const Eigen::Matrix3d& R_sensor_imu, double max_gap,
                                        const Eigen::Vector3d& body_velocity = Eigen::Vector3d::Zero());

/// @brief The rotation of the track from begin_utime to end_utime (R(begin)^T R(end)), nullopt unless both lie within
///        it (between samples: slerp).
std::optional<Eigen::Matrix3d> gyro_rotation(const std::vector<StampedPose>& track, std::int64_t begin_utime, std::int64_t end_utime, double max_gap);

/// @brief R_sensor_imu from roll, pitch, yaw [deg] (R = Rz(yaw) Ry(pitch) Rx(roll)).
Eigen::Matrix3d rotation_from_rpy_deg(double roll, double pitch, double yaw);

}  // namespace loopd
