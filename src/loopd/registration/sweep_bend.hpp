#pragma once
/// @file The part of a sweep's motion that a constant velocity does not hold, read from a track of poses through the
/// sweep (a gyro's, integrated: integrate_gyro): the path through the sweep relative to the screw motion between the
/// track's poses at its two ends. Scan registration measures the motion between two stamps, while a gyro sampled at
/// hundreds of hertz follows a turn rate that changes inside the sweep, which no motion measured between two stamps
/// can: estimate_sweep_motion takes the increment from the scans and this bend from the gyro.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief B(t) = Screw(t / d)^-1 * T_odom_sensor(stamp)^-1 * T_odom_sensor(stamp + t) for t in [-d, 0] (seconds
///        relative to the sweep's stamp, d the time to the stamp before it), where Screw(a) = interpolate_screw(I,
///        Delta, a) and Delta the odometry's motion from stamp - d to the stamp: identity at both ends, and everywhere
///        when the odometry moved at one velocity. Sampled at the odometry's poses inside the sweep.
class SweepBend {
 public:
  SweepBend() = default;
  /// @param poses T_odom_sensor around the sweep, sorted by utime; @param stamp_utime the sweep's stamp [us];
  /// @param sweep_dt d [s]; @param max_pose_gap [s] poses farther apart leave no bend. Empty (no bend) unless at least
  /// one pose lies strictly inside (stamp - d, stamp) and the poses reach both ends.
  static SweepBend from_poses(const std::vector<StampedPose>& poses, std::int64_t stamp_utime, double sweep_dt, double max_pose_gap);
  bool empty() const { return times_.empty(); }
  /// @brief B(t) [t in s relative to the stamp], the screw motion between the samples; identity outside [-d, 0].
  Eigen::Isometry3d at(double t) const;
  /// @brief The sample times [s, relative to the stamp, increasing]: -d, the inner poses' times, 0.
  const std::vector<double>& times() const { return times_; }
  /// @brief The largest rotation of a sample off the constant-velocity path [deg].
  double max_rotation_deg() const;

 private:
  std::vector<double> times_;
  std::vector<Eigen::Isometry3d> bends_;
};

}  // namespace loopd
