#include "loopd/pipeline/keyframe_selector.hpp"

#include <algorithm>
#include <cmath>

namespace loopd {

std::optional<std::string> KeyframeConfig::validate() const {
  if (!(min_distance >= 0.0)) return "keyframe.min_distance must be >= 0";
  if (!(min_rotation_deg >= 0.0 && min_rotation_deg <= 180.0)) return "keyframe.min_rotation_deg must be in [0, 180]";
  if (!(max_interval >= 0.0)) return "keyframe.max_interval must be >= 0";
  if (!(spacing_per_scale >= 0.0 && std::isfinite(spacing_per_scale))) return "keyframe.spacing_per_scale must be >= 0";
  if (!(min_spacing >= 0.0 && std::isfinite(min_spacing))) return "keyframe.min_spacing must be >= 0 [m]";
  return std::nullopt;
}

double KeyframeSelector::spacing(double scene_scale) const {
  if (!(config_.spacing_per_scale > 0.0 && scene_scale > 0.0)) return config_.min_distance;
  return std::min(config_.min_distance, std::max(config_.min_spacing, config_.spacing_per_scale * scene_scale));
}

bool KeyframeSelector::accept(const Eigen::Isometry3d& T_odom_sensor, std::int64_t utime, double scene_scale) {
  return accept(T_odom_sensor, utime, [scene_scale] { return scene_scale; });
}

bool KeyframeSelector::accept(const Eigen::Isometry3d& T_odom_sensor, std::int64_t utime, const std::function<double()>& scene_scale_of_scan) {
  bool take = !has_last_;
  if (!take) {
    const Eigen::Isometry3d delta = last_pose_.inverse() * T_odom_sensor;  // Ren 2019, Eq. (8)
    const double ds = delta.translation().norm();
    const double dr = rotation_angle(delta) * 180.0 / M_PI;
    const double dt = static_cast<double>(utime - last_utime_) * 1e-6;
    take = ds >= config_.min_distance || dr >= config_.min_rotation_deg || (config_.max_interval > 0.0 && dt >= config_.max_interval);
    // The scaled rule lies in [min(min_spacing, min_distance), min_distance]: only a scan in that band needs its scale.
    const bool scaled = config_.spacing_per_scale > 0.0 && ds >= std::min(config_.min_spacing, config_.min_distance);
    if (!take && scaled) take = ds >= spacing(scene_scale_of_scan());
  }
  if (take) {
    has_last_ = true;
    last_pose_ = T_odom_sensor;
    last_utime_ = utime;
  }
  return take;
}

}  // namespace loopd
