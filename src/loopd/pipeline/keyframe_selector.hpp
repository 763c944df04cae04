#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include "loopd/core/pose.hpp"

namespace loopd {

/// @brief Keyframe rule of Ren 2019, Sec. 3.3.2: a scan becomes a keyframe when the distance, the rotation
///        or the time since the last keyframe exceeds its threshold.
struct KeyframeConfig {
  double min_distance = 2.0;       ///< [m] translation since the last keyframe
  double min_rotation_deg = 15.0;  ///< [deg] rotation since the last keyframe
  double max_interval = 10.0;      ///< [s] time since the last keyframe (0 disables)
  std::optional<std::string> validate() const;
};

/// @brief Decides which scans become keyframes (first scan always does).
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeConfig& config) : config_(config) {}
  /// @brief True when the scan at this odometry pose and time should be a keyframe; remembers it if so.
  bool accept(const Eigen::Isometry3d& T_odom_sensor, std::int64_t utime);

 private:
  KeyframeConfig config_;
  bool has_last_ = false;
  Eigen::Isometry3d last_pose_ = Eigen::Isometry3d::Identity();
  std::int64_t last_utime_ = 0;
};

}  // namespace loopd
