#pragma once
// bag2lcm's conversion: a ROS 1 bag (read by rosbag_storage) -> an lcm-logger drive log as loopd-sim writes it.
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace loopd::bag2lcm {

struct Options {
  std::string bag, out;
  std::string cloud_topic;
  std::string odom_topic;  ///< nav_msgs/Odometry; or, when empty, the TF chain tf_parent -> tf_child
  std::string tf_parent, tf_child;
  std::string gt_topic;   ///< optional: nav_msgs/Odometry or geometry_msgs/PoseStamped
  std::string imu_topic;  ///< optional: sensor_msgs/Imu, written as imu_t turned into the scans' frame (/tf_static)
  std::string tf_topic = "/tf", tf_static_topic = "/tf_static";
  std::string base_frame;    ///< the body the odometry gives the pose of (default: its child_frame_id, or tf_child)
  std::string gt_frame;      ///< the body of a PoseStamped ground truth (default: base_frame)
  std::string sensor_frame;  ///< default: the first scan's frame_id
  std::string scan_channel = "LIDAR_SCAN", odom_channel = "ODOMETRY_POSE", gt_channel = "GROUND_TRUTH_POSE", imu_channel = "IMU";
  int rings = 0;  ///< number of rings; 0: from the ring indices (largest + 1, rounded up to a multiple of 8)
  std::uint64_t max_points = 4000000;
  bool progress = true;
};

/// @brief Messages read and written for one topic, and those skipped by reason.
struct TopicStats {
  std::string topic, role, type, channel;
  std::int64_t in = 0;      ///< messages read
  std::int64_t out = 0;     ///< messages written
  std::int64_t unused = 0;  ///< read but not needed (e.g. /tf messages that do not move the chain)
  struct Skip {
    std::int64_t count = 0;
    std::string first;  ///< "message N: detail" of the first one
  };
  std::map<std::string, Skip> skipped;  ///< by reason
  std::map<std::string, Skip> noted;    ///< written, but with something left out (e.g. unusable per-point times), by reason
  std::int64_t skipped_total() const {
    std::int64_t n = 0;
    for (const auto& [reason, s] : skipped) n += s.count;
    return n;
  }
};

/// @brief What a conversion did; ok == false with `error` (naming the topic and message index where there is one).
struct Report {
  bool ok = false;
  std::string error;
  bool converted = false;  ///< the main pass ran (the statistics are meaningful)
  std::string bag, out;
  std::int64_t bag_bytes = 0, out_bytes = 0;
  double seconds = 0.0;
  std::vector<TopicStats> topics;
  std::string sensor_frame, base_frame, gt_frame;
  Eigen::Isometry3d T_base_sensor = Eigen::Isometry3d::Identity();
  std::int64_t points_in = 0, points_out = 0, points_nonfinite = 0;
  int num_rings = 0;
  std::set<std::string> ring_fields, intensity_fields, time_fields;  ///< the fields the scans' rings, intensities and times came from
  std::int64_t scans_with_times = 0;                                 ///< scans written with per-point times (point_cloud_t.time_offset)
};

/// @brief Where the conversion is reading, in memory the parent process reads when rosbag_storage crashes the child.
struct Position {
  char topic[256] = {};
  std::int64_t index = -1;
  char phase[64] = {};
};

/// @brief Converts options.bag into options.out. Never throws; on failure the output file is removed.
Report convert_bag(const Options& options, Position* where);

}  // namespace loopd::bag2lcm
