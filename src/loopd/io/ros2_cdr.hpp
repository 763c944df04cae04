#pragma once
/// @file The ROS 2 messages bag2lcm reads, decoded from CDR (XCDR1, the "cdr" message encoding of ROS 2 bags): the
/// 4-byte encapsulation header (little or big endian), then the fields with each primitive aligned to its size from
/// the start of the payload, strings and sequences with a uint32 length. Every length and count is checked against
/// the bytes left before anything is allocated or read; a message that does not fit is refused with the field named.
/// ROS-free: sensor_msgs/msg/PointCloud2, nav_msgs/msg/Odometry, geometry_msgs/msg/PoseStamped, tf2_msgs/msg/TFMessage.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/io/pointcloud2_layout.hpp"

namespace loopd {

/// @brief std_msgs/msg/Header.
struct Ros2Header {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::string frame_id;
  /// [us] since the epoch (nanoseconds truncated).
  std::int64_t utime() const { return std::int64_t{sec} * 1000000 + std::int64_t{nanosec} / 1000; }
};

/// @brief geometry_msgs/msg/Pose: position x, y, z; orientation x, y, z, w.
struct Ros2Pose {
  double position[3] = {0, 0, 0};
  double orientation[4] = {0, 0, 0, 1};
};

/// @brief sensor_msgs/msg/PointCloud2: the layout (decode_pointcloud2's input) and where its data bytes lie in the
/// message (valid while the message's bytes are).
struct Ros2PointCloud2 {
  Ros2Header header;
  PointCloud2Layout layout;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  bool is_dense = false;
};

/// @brief nav_msgs/msg/Odometry (the pose; the covariances and the twist are read past).
struct Ros2Odometry {
  Ros2Header header;
  std::string child_frame_id;
  Ros2Pose pose;
};

/// @brief geometry_msgs/msg/PoseStamped.
struct Ros2PoseStamped {
  Ros2Header header;
  Ros2Pose pose;
};

/// @brief geometry_msgs/msg/TransformStamped.
struct Ros2Transform {
  Ros2Header header;
  std::string child_frame_id;
  double translation[3] = {0, 0, 0};
  double rotation[4] = {0, 0, 0, 1};  ///< x, y, z, w
};

/// @brief tf2_msgs/msg/TFMessage.
struct Ros2TfMessage {
  std::vector<Ros2Transform> transforms;
};

/// @brief Decode one message from its CDR bytes; false and `error` (the field that does not fit) otherwise. Bytes
/// after the message's last field are allowed (CDR pads to 4).
bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2PointCloud2* out, std::string* error);
bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2Odometry* out, std::string* error);
bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2PoseStamped* out, std::string* error);
bool decode_cdr(const std::uint8_t* data, std::size_t size, Ros2TfMessage* out, std::string* error);

}  // namespace loopd
