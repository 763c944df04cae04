#include "ros_convert.hpp"

#include <cmath>

namespace loopd::bag2lcm {
namespace {

constexpr double kMaxPosition = 1e7;  ///< [m] as loopd's pose_t check (message_convert.hpp)

bool make(double px, double py, double pz, double qx, double qy, double qz, double qw, Eigen::Isometry3d* T, std::string* why) {
  for (double v : {px, py, pz, qx, qy, qz, qw})
    if (!std::isfinite(v)) {
      *why = "a position or orientation number is not finite";
      return false;
    }
  if (std::abs(px) > kMaxPosition || std::abs(py) > kMaxPosition || std::abs(pz) > kMaxPosition) {
    *why = "position beyond 1e7 m";
    return false;
  }
  Eigen::Quaterniond q(qw, qx, qy, qz);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 0.01) {
    *why = "orientation quaternion of length " + std::to_string(norm) + ", not 1";
    return false;
  }
  q.normalize();
  T->setIdentity();
  T->linear() = q.toRotationMatrix();
  T->translation() = Eigen::Vector3d(px, py, pz);
  return true;
}

}  // namespace

bool to_isometry(const geometry_msgs::Pose& p, Eigen::Isometry3d* T, std::string* why) {
  return make(p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w, T, why);
}

bool to_isometry(const geometry_msgs::Transform& t, Eigen::Isometry3d* T, std::string* why) {
  return make(t.translation.x, t.translation.y, t.translation.z, t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w, T, why);
}

PointCloud2Layout layout_of(const sensor_msgs::PointCloud2& msg) {
  PointCloud2Layout l;
  l.height = msg.height;
  l.width = msg.width;
  l.is_bigendian = msg.is_bigendian != 0;
  l.point_step = msg.point_step;
  l.row_step = msg.row_step;
  l.fields.reserve(msg.fields.size());
  for (const auto& f : msg.fields) l.fields.push_back(PointFieldLayout{f.name, f.offset, f.datatype, f.count});
  return l;
}

PointCloud2Decoded decode_cloud(const sensor_msgs::PointCloud2& msg, const PointCloud2Options& options) {
  return decode_pointcloud2(layout_of(msg), msg.data.data(), msg.data.size(), options);
}

}  // namespace loopd::bag2lcm
