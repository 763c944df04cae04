#pragma once
// ROS 1 messages -> loopd types: stamps to microseconds, poses and transforms to isometries (checked), a PointCloud2
// to loopd's PointCloud through the ROS-free decoder in loopd/io/pointcloud2_layout.hpp.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>

#include "loopd/io/pointcloud2_layout.hpp"

namespace loopd::bag2lcm {

/// @brief Microseconds since the epoch of a ROS stamp (nanoseconds truncated, as ros::Time::toNSec() / 1000).
inline std::int64_t to_utime(const ros::Time& t) { return std::int64_t{t.sec} * 1000000 + std::int64_t{t.nsec} / 1000; }

/// @brief T from a position and an (x, y, z, w) quaternion; false (and `why`) when a number is not finite, the
///        position is beyond 1e7 m or the quaternion is not of unit length (within 1 %). The quaternion is normalised.
bool to_isometry(const geometry_msgs::Pose& pose, Eigen::Isometry3d* T, std::string* why);
bool to_isometry(const geometry_msgs::Transform& transform, Eigen::Isometry3d* T, std::string* why);

/// @brief The layout fields of a PointCloud2 message.
PointCloud2Layout layout_of(const sensor_msgs::PointCloud2& msg);

/// @brief Decodes the message's points (see decode_pointcloud2).
PointCloud2Decoded decode_cloud(const sensor_msgs::PointCloud2& msg, const PointCloud2Options& options);

}  // namespace loopd::bag2lcm
