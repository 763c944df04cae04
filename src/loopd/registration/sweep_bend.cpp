#include "loopd/registration/sweep_bend.hpp"

#include <algorithm>

#include "loopd/base/angles.hpp"
#include "loopd/base/deskew.hpp"

namespace loopd {

SweepBend SweepBend::from_poses(const std::vector<StampedPose>& poses, std::int64_t stamp_utime, double sweep_dt, double max_pose_gap) {
  SweepBend bend;
  if (!(sweep_dt > 0.0)) return bend;
  const auto begin_utime = stamp_utime - static_cast<std::int64_t>(sweep_dt * 1e6 + 0.5);
  std::vector<double> inner;
  for (const StampedPose& p : poses)
    if (p.utime > begin_utime && p.utime < stamp_utime) inner.push_back(static_cast<double>(p.utime - stamp_utime) * 1e-6);
  if (inner.empty()) return bend;
  const PoseTrack track(poses, stamp_utime, max_pose_gap);
  const auto stamp = track.at(0.0, 0.0), start = track.at(-sweep_dt, 0.0);
  if (!stamp || !start) return bend;
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity(), T_stamp_odom = stamp->inverse(), delta = start->inverse() * *stamp;
  bend.times_.push_back(-sweep_dt);
  bend.bends_.push_back(I);
  for (const double t : inner) {
    const auto T = track.at(t, 0.0);
    if (!T) return SweepBend{};
    bend.times_.push_back(t);
    bend.bends_.push_back(interpolate_screw(I, delta, t / sweep_dt).inverse() * T_stamp_odom * *T);
  }
  bend.times_.push_back(0.0);
  bend.bends_.push_back(I);
  return bend;
}

Eigen::Isometry3d SweepBend::at(double t) const {
  if (times_.empty() || t <= times_.front() || t >= times_.back()) return Eigen::Isometry3d::Identity();
  const auto k = static_cast<std::size_t>(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());
  const double a = (t - times_[k - 1]) / (times_[k] - times_[k - 1]);
  return interpolate_screw(bends_[k - 1], bends_[k], a);
}

double SweepBend::max_rotation_deg() const {
  double m = 0.0;
  for (const auto& B : bends_) m = std::max(m, rotation_angle(B));
  return m * 180.0 / kPi;
}

}  // namespace loopd
