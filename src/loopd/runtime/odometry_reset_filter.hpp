#pragma once
#include <cstdint>
#include <optional>

#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief Keeps the odometry frame continuous across odometry resets. When the odometry process restarts, its
///        poses jump back to identity (or to wherever it re-initialises); a jump faster than the vehicle can move
///        is such a reset, and so is a pose of exactly identity after one that was not (a restart near the origin). From then on every pose is
///        re-expressed so that the trajectory continues from the last pose before the reset (zero motion across the reset, the only assumption that
///        needs no other sensor), and the distance gate and pose graph go on working in one frame. Each reset is counted.
class OdometryResetFilter {
 public:
  struct Config {
    double max_speed = 60.0;           ///< [m/s] faster apparent motion is a reset (60 m/s = 216 km/h)
    double max_turn_rate_deg = 360.0;  ///< [deg/s] faster apparent rotation is a reset
    double min_jump = 2.0;             ///< [m] smaller jumps are never resets (noise, a skipped pose)
  };
  OdometryResetFilter() = default;
  explicit OdometryResetFilter(const Config& config) : config_(config) {}

  /// @brief The pose in the continuous frame; `reset` is set when this pose starts a new odometry segment.
  StampedPose apply(const StampedPose& raw, bool* reset = nullptr);
  std::int64_t resets() const { return resets_; }
  /// @brief Continuous frame <- current odometry frame.
  const Eigen::Isometry3d& T_continuous_odom() const { return T_continuous_odom_; }
  /// @brief Forget the previous pose (after a clock jump: its time cannot be compared with the next one's).
  void forget_last() { last_raw_.reset(); }

 private:
  Config config_;
  std::optional<StampedPose> last_raw_;
  Eigen::Isometry3d T_continuous_odom_ = Eigen::Isometry3d::Identity();
  std::int64_t resets_ = 0;
};

}  // namespace loopd
