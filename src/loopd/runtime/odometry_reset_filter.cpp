#include "loopd/runtime/odometry_reset_filter.hpp"

#include <algorithm>
#include <cmath>

namespace loopd {

StampedPose OdometryResetFilter::apply(const StampedPose& raw, bool* reset) {
  bool is_reset = false;
  if (last_raw_ && raw.utime > last_raw_->utime) {
    const double dt = static_cast<double>(raw.utime - last_raw_->utime) * 1e-6;
    const Eigen::Isometry3d T_last_now = last_raw_->T_world_sensor.inverse() * raw.T_world_sensor;
    const double moved = T_last_now.translation().norm();
    const double turned_deg = Eigen::AngleAxisd(T_last_now.rotation()).angle() * 180.0 / M_PI;
    const bool too_far = moved > std::max(config_.min_jump, config_.max_speed * dt);
    const bool too_fast_turn = turned_deg > std::max(30.0, config_.max_turn_rate_deg * dt);
    // A restarted odometry process starts again at exactly identity: a reset even when it happens near its origin.
    const bool restarted =
        raw.T_world_sensor.matrix() == Eigen::Matrix4d::Identity() && last_raw_->T_world_sensor.matrix() != Eigen::Matrix4d::Identity();
    if (too_far || too_fast_turn || restarted) {
      // Continue from the last pose: continuous <- new odom = (continuous <- last) * (new odom pose)^-1.
      const Eigen::Isometry3d T_continuous_last = T_continuous_odom_ * last_raw_->T_world_sensor;
      T_continuous_odom_ = T_continuous_last * raw.T_world_sensor.inverse();
      ++resets_;
      is_reset = true;
    }
  }
  last_raw_ = raw;
  if (reset) *reset = is_reset;
  StampedPose out = raw;
  out.T_world_sensor = T_continuous_odom_ * raw.T_world_sensor;
  return out;
}

}  // namespace loopd
