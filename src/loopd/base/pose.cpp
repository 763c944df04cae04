#include "loopd/base/pose.hpp"

#include <algorithm>
#include <cmath>

namespace loopd {

Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha) {
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = qa.slerp(alpha, qb).normalized().toRotationMatrix();
  out.translation() = (1.0 - alpha) * a.translation() + alpha * b.translation();
  return out;
}

namespace {

Eigen::Matrix3d hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d W;
  W << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return W;
}

/// V(w) of SE(3)'s exponential, t = V(w) v (Barfoot 2017, Eq. 7.86; series below 1e-4 rad).
Eigen::Matrix3d se3_v(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const Eigen::Matrix3d W = hat(w);
  if (theta < 1e-4) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 6.0;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * W + (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

}  // namespace

Eigen::Isometry3d interpolate_screw(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double alpha) {
  const Eigen::Isometry3d D = a.inverse() * b;
  const Eigen::AngleAxisd aa(D.linear());
  const Eigen::Vector3d w = aa.axis() * aa.angle();
  const Eigen::Vector3d v = se3_v(w).inverse() * D.translation();  // 3x3, well conditioned for |w| < 2 pi
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d aw = alpha * w;
  step.linear() = Eigen::AngleAxisd(aw.norm(), aw.norm() > 0.0 ? Eigen::Vector3d(aw.normalized()) : Eigen::Vector3d::UnitZ()).toRotationMatrix();
  step.translation() = se3_v(aw) * (alpha * v);
  return a * step;
}

double rotation_angle(const Eigen::Isometry3d& T) {
  const double c = std::clamp((T.linear().trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c);
}

Eigen::Isometry3d make_isometry(const double position[3], const double q[4]) {
  Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (quat.norm() < 1e-12) quat = Eigen::Quaterniond::Identity();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = quat.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(position[0], position[1], position[2]);
  return T;
}

void to_row_major(const Eigen::Isometry3d& T, double out[16]) {
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[r * 4 + c] = M(r, c);
}

Eigen::Isometry3d from_row_major(const double in[16]) {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = in[r * 4 + c];
    t(r) = in[r * 4 + 3];
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

Eigen::Isometry3d make_isometry(double x, double y, double z, double yaw, double pitch, double roll) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

}  // namespace loopd
