#include "loopd/sim/odometry_stream.hpp"

#include "loopd/sim/sample_grid.hpp"

namespace loopd {

std::vector<StampedPose> odometry_between_scans(const Drive& drive, int scan_index, double rate_hz) {
  std::vector<StampedPose> out;
  if (scan_index < 1 || scan_index >= static_cast<int>(drive.scans.size()) || !(rate_hz > drive.config.rate_hz)) return out;
  const DriveScan& a = drive.scans[static_cast<std::size_t>(scan_index - 1)];
  const DriveScan& b = drive.scans[static_cast<std::size_t>(scan_index)];
  if (a.odometry_segment != b.odometry_segment) return out;  // the odometry restarted at this scan
  const Eigen::Isometry3d true_step = a.T_world_sensor.inverse() * b.T_world_sensor;
  const Eigen::Isometry3d drift = true_step.inverse() * (a.odometry.T_world_sensor.inverse() * b.odometry.T_world_sensor);
  const double step_s = static_cast<double>(b.utime - a.utime) * 1e-6;
  for (const GridTime g : grid_times(drive.config.start_utime, rate_hz, a.utime, b.utime - 1)) {  // strictly between the scans
    const std::int64_t utime = g.utime;
    const double t = static_cast<double>(utime - a.utime) * 1e-6;  // [s] after scan i - 1
    const Eigen::Isometry3d T_true = drive.pose_at_distance(a.route_distance + drive.config.speed * t);
    const Eigen::Isometry3d moved = a.T_world_sensor.inverse() * T_true;
    out.push_back({utime, a.odometry.T_world_sensor * moved * interpolate_screw(Eigen::Isometry3d::Identity(), drift, t / step_s), 0.0});
  }
  return out;
}

}  // namespace loopd
