#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief Keyframe rule of Ren 2019, Sec. 3.3.2: a scan becomes a keyframe when the distance, the rotation
///        or the time since the last keyframe exceeds its threshold.
struct KeyframeConfig {
  double min_distance = 2.0;       ///< [m] translation since the last keyframe
  double min_rotation_deg = 15.0;  ///< [deg] rotation since the last keyframe
  double max_interval = 10.0;      ///< [s] time since the last keyframe (0 disables)
  /// Scale from the scene: the distance rule is min(min_distance, this x the scan's scene_scale()), so keyframes of a
  /// walk through a courtyard (scale 10-20 m) lie 0.7-1.3 m apart and a car's in a street (40-80 m) min_distance apart.
  /// 0: off.
  double spacing_per_scale = 0.0667;
  /// [m] the scaled distance rule is never below this. In a tunnel (scale 3-6 m) 0.25 m made nearly every scan a
  /// keyframe (973 instead of 251 on the 1000-scan mine drive) for no better closure.
  double min_spacing = 1.0;
  std::optional<std::string> validate() const;
};

/// @brief Decides which scans become keyframes (first scan always does).
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeConfig& config) : config_(config) {}
  /// @brief True when the scan at this odometry pose and time should be a keyframe; remembers it if so.
  /// @param scene_scale [m] the scan's scene_scale() (0: unknown, min_distance as configured)
  bool accept(const Eigen::Isometry3d& T_odom_sensor, std::int64_t utime, double scene_scale = 0.0);
  /// @brief As above, with the scene scale asked for only when the decision depends on it (the scan has moved
  ///        between min_spacing and min_distance and no other rule fires): most scans never pay for it.
  bool accept(const Eigen::Isometry3d& T_odom_sensor, std::int64_t utime, const std::function<double()>& scene_scale_of_scan);
  /// @brief [m] The distance rule for a scan of this scene scale.
  double spacing(double scene_scale) const;

 private:
  KeyframeConfig config_;
  bool has_last_ = false;
  Eigen::Isometry3d last_pose_ = Eigen::Isometry3d::Identity();
  std::int64_t last_utime_ = 0;
};

}  // namespace loopd
