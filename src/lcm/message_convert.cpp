#include "message_convert.hpp"

#include <cmath>

namespace loopd {

point_cloud_t to_message(const PointCloud& cloud, std::int64_t utime, std::int64_t seq, const std::string& frame) {
  point_cloud_t msg;
  msg.utime = utime;
  msg.seq = seq;
  msg.frame = frame;
  const std::size_t n = cloud.size();
  msg.num_points = static_cast<int32_t>(n);
  msg.x.resize(n);
  msg.y.resize(n);
  msg.z.resize(n);
  msg.intensity.assign(n, 0.f);
  for (std::size_t i = 0; i < n; ++i) {
    msg.x[i] = cloud.points[i].x();
    msg.y[i] = cloud.points[i].y();
    msg.z[i] = cloud.points[i].z();
    if (cloud.has_intensity()) msg.intensity[i] = cloud.intensity[i];
  }
  if (cloud.has_rings()) {
    msg.num_ring_indices = static_cast<int32_t>(n);
    msg.ring.assign(cloud.ring.begin(), cloud.ring.end());
  } else {
    msg.num_ring_indices = 0;
  }
  msg.num_rings = static_cast<int16_t>(cloud.num_rings);
  if (cloud.has_time()) {
    msg.num_point_times = static_cast<int32_t>(n);
    msg.time_offset = cloud.time;
  } else {
    msg.num_point_times = 0;
  }
  return msg;
}

std::string ring_indices_error(std::int64_t num_points, std::int64_t num_ring_indices) {
  if (num_ring_indices == 0 || num_ring_indices == num_points) return "";
  return "point_cloud_t num_ring_indices is neither 0 nor num_points";
}

std::string num_rings_error(std::int64_t num_rings) {
  if (num_rings >= 0 && num_rings <= kMaxRings) return "";
  return "point_cloud_t num_rings = " + std::to_string(num_rings) + " is outside 0.." + std::to_string(kMaxRings);
}

std::string point_time_error(float t) {
  return "point_cloud_t time_offset " + std::to_string(t) + " s is not finite or beyond " + std::to_string(kMaxPointTimeOffset) + " s";
}

bool from_message(const point_cloud_t& msg, PointCloud* cloud, std::string* error) {
  const auto n = static_cast<std::size_t>(msg.num_points);
  if (msg.num_points < 0 || msg.x.size() != n || msg.y.size() != n || msg.z.size() != n || msg.intensity.size() != n) {
    *error = "point_cloud_t arrays disagree with num_points";
    return false;
  }
  *error = ring_indices_error(msg.num_points, msg.num_ring_indices);
  if (error->empty()) *error = num_rings_error(msg.num_rings);
  if (!error->empty()) return false;
  const bool has_times = msg.num_point_times != 0;
  if ((has_times && msg.num_point_times != msg.num_points) || (has_times && msg.time_offset.size() != n)) {
    *error = "point_cloud_t num_point_times is neither 0 nor num_points";
    return false;
  }
  for (std::size_t i = 0; has_times && i < n; ++i) {
    if (point_time_ok(msg.time_offset[i])) continue;
    *error = point_time_error(msg.time_offset[i]);
    return false;
  }
  *cloud = PointCloud();
  cloud->points.resize(n);
  for (std::size_t i = 0; i < n; ++i) cloud->points[i] = Eigen::Vector3f(msg.x[i], msg.y[i], msg.z[i]);
  cloud->intensity = msg.intensity;
  if (msg.num_ring_indices == msg.num_points && msg.num_rings > 0) {
    cloud->ring.resize(n);
    for (std::size_t i = 0; i < n; ++i) cloud->ring[i] = static_cast<std::uint16_t>(msg.ring[i] < 0 ? 0 : msg.ring[i]);
    cloud->num_rings = msg.num_rings;
  }
  if (has_times) cloud->time = msg.time_offset;
  return true;
}

pose_t to_message(const StampedPose& pose, std::int64_t seq) {
  pose_t msg{};
  msg.utime = pose.utime;
  msg.seq = seq;
  const Eigen::Vector3d t = pose.T_world_sensor.translation();
  const Eigen::Quaterniond q(pose.T_world_sensor.linear());
  for (int i = 0; i < 3; ++i) msg.position[i] = t[i];
  msg.orientation[0] = q.w();
  msg.orientation[1] = q.x();
  msg.orientation[2] = q.y();
  msg.orientation[3] = q.z();
  msg.residual = pose.residual;
  msg.has_covariance = 0;
  for (double& c : msg.covariance) c = 0.0;
  return msg;
}

bool from_message(const pose_t& msg, StampedPose* pose, std::string* error) {
  for (double v : msg.position)
    if (!std::isfinite(v) || std::abs(v) > kMaxPosition) {
      *error = std::isfinite(v) ? "pose_t position " + std::to_string(v) + " m is beyond 1e7 m" : "pose_t position is not finite";
      return false;
    }
  double qn = 0.0;
  for (double v : msg.orientation) {
    if (!std::isfinite(v)) {
      *error = "pose_t orientation is not finite";
      return false;
    }
    qn += v * v;
  }
  if (qn < 1e-12 || qn > 1e12) {
    *error = "pose_t orientation is a zero or huge quaternion";
    return false;
  }
  if (!std::isfinite(msg.residual) || msg.residual < 0.0 || msg.residual > kMaxPosition) {
    *error = "pose_t residual is negative, not finite or beyond 1e7 m";
    return false;
  }
  pose->utime = msg.utime;
  pose->T_world_sensor = make_isometry(msg.position, msg.orientation);
  pose->residual = msg.residual;
  return true;
}

imu_t to_message(const ImuSample& sample, std::int64_t seq) {
  imu_t m{};
  m.utime = sample.utime;
  m.seq = seq;
  for (int i = 0; i < 3; ++i) m.angular_velocity[i] = sample.angular_velocity[i];
  return m;
}

bool from_message(const imu_t& msg, ImuSample* sample, std::string* error) {
  for (double v : msg.angular_velocity)
    if (!(std::abs(v) <= kMaxTurnRate)) {  // NaN fails too
      *error = std::isfinite(v) ? "imu_t turn rate " + std::to_string(v) + " rad/s is beyond 100 rad/s" : "imu_t turn rate is not finite";
      return false;
    }
  sample->utime = msg.utime;
  sample->angular_velocity = Eigen::Vector3d(msg.angular_velocity[0], msg.angular_velocity[1], msg.angular_velocity[2]);
  return true;
}

}  // namespace loopd
