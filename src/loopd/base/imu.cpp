#include "loopd/base/imu.hpp"

#include "loopd/base/angles.hpp"
#include "loopd/base/deskew.hpp"

namespace loopd {

std::vector<StampedPose> integrate_gyro(const std::vector<ImuSample>& samples, const Eigen::Matrix3d& R_sensor_imu, double max_gap,
                                        const Eigen::Vector3d& body_velocity) {
  std::vector<StampedPose> track;
  if (samples.empty()) return track;
  track.reserve(samples.size());
  track.push_back({samples.front().utime, Eigen::Isometry3d::Identity(), 0.0});
  for (std::size_t k = 1; k < samples.size(); ++k) {
    const double dt = static_cast<double>(samples[k].utime - samples[k - 1].utime) * 1e-6;
    if (!(dt > 0.0) || dt > max_gap) break;
    const Eigen::Vector3d w = R_sensor_imu * samples[k].angular_velocity * dt;
    const double angle = w.norm();
    const Eigen::Isometry3d& last = track.back().T_world_sensor;
    const Eigen::Matrix3d turn = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    const Eigen::Matrix3d half = angle > 0.0 ? Eigen::AngleAxisd(0.5 * angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    StampedPose p{samples[k].utime, last, 0.0};
    p.T_world_sensor.linear() = last.linear() * turn;
    p.T_world_sensor.translation() = last.translation() + last.linear() * half * body_velocity * dt;  // midpoint heading
    track.push_back(p);
  }
  return track;
}

std::optional<Eigen::Matrix3d> gyro_rotation(const std::vector<StampedPose>& track, std::int64_t begin_utime, std::int64_t end_utime,
                                             double max_gap) {
  if (track.size() < 2) return std::nullopt;
  const PoseTrack t(track, end_utime, max_gap);
  const auto begin = t.at(static_cast<double>(begin_utime - end_utime) * 1e-6, 0.0), end = t.at(0.0, 0.0);
  if (!begin || !end) return std::nullopt;
  return Eigen::Matrix3d(begin->linear().transpose() * end->linear());
}

Eigen::Matrix3d rotation_from_rpy_deg(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw * kRadPerDeg, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch * kRadPerDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll * kRadPerDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace loopd
