#include "loopd/runtime/scan_pose_associator.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/base/deskew.hpp"

namespace loopd {

std::optional<std::string> AssociationConfig::validate() const {
  // Both become int64 microseconds (seconds * 1e6); 1e6 s keeps that far inside the int64 range.
  constexpr double kMaxSeconds = 1e6;
  if (!(tolerance > 0.0 && tolerance <= kMaxSeconds)) return "association.tolerance must be > 0 and <= 1e6 [s]";
  if (!(hold_time > 0.0 && hold_time <= kMaxSeconds)) return "association.hold_time must be > 0 and <= 1e6 [s]";
  if (max_pending_scans < 1) return "association.max_pending_scans must be >= 1";
  if (max_poses < 2) return "association.max_poses must be >= 2";
  return std::nullopt;
}

bool ScanPoseAssociator::add_pose(const StampedPose& pose) {
  if (!poses_.empty() && pose.utime <= poses_.back().utime) {
    ++rejected_pose_order_;
    return false;
  }
  poses_.push_back(pose);
  while (static_cast<int>(poses_.size()) > config_.max_poses) poses_.pop_front();
  return true;
}

bool ScanPoseAssociator::add_scan(std::int64_t utime, PointCloud cloud, double wall_time_s) {
  if (last_scan_utime_ && utime <= *last_scan_utime_) {
    ++rejected_scan_order_;
    return false;
  }
  last_scan_utime_ = utime;
  std::int64_t sweep_begin = utime, sweep_end = utime;
  if (sweep_poses_ && cloud.has_time()) {
    const auto [t0, t1] = time_span(cloud);
    sweep_begin = utime + static_cast<std::int64_t>(std::floor(t0 * 1e6));
    sweep_end = utime + static_cast<std::int64_t>(std::ceil(t1 * 1e6));
  }
  scans_.push_back({utime, std::move(cloud), wall_time_s, sweep_begin, sweep_end});
  while (static_cast<int>(scans_.size()) > config_.max_pending_scans) {
    scans_.pop_front();
    ++dropped_no_pose_;
  }
  return true;
}

void ScanPoseAssociator::restart_scans() {
  dropped_no_pose_ += static_cast<std::int64_t>(scans_.size());
  scans_.clear();
  last_scan_utime_.reset();
  last_resolved_utime_.reset();
}

void ScanPoseAssociator::restart_poses() {
  poses_.clear();
  last_resolved_utime_.reset();
}

std::optional<StampedPose> ScanPoseAssociator::pose_at(std::int64_t utime) const {
  if (poses_.empty()) return std::nullopt;
  const auto tol = static_cast<std::int64_t>(config_.tolerance * 1e6);
  auto it = std::lower_bound(poses_.begin(), poses_.end(), utime, [](const StampedPose& p, std::int64_t t) { return p.utime < t; });
  if (it != poses_.end() && it->utime == utime) return *it;  // exact match
  if (it == poses_.end() || it == poses_.begin()) return std::nullopt;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  if (utime - a.utime > tol || b.utime - utime > tol) return std::nullopt;
  const double alpha = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
  StampedPose p;
  p.utime = utime;
  p.T_world_sensor = interpolate(a.T_world_sensor, b.T_world_sensor, alpha);
  p.residual = b.residual;
  return p;
}

double ScanPoseAssociator::residual_between(std::int64_t from, std::int64_t to) const {
  double sum = 0.0;
  for (const auto& p : poses_)
    if (p.utime > from && p.utime <= to) sum += p.residual;
  return sum;
}

std::vector<StampedPose> ScanPoseAssociator::poses_around(std::int64_t from, std::int64_t to) const {
  const auto before = [](const StampedPose& p, std::int64_t t) { return p.utime < t; };
  const auto after = [](std::int64_t t, const StampedPose& p) { return t < p.utime; };
  auto lo = std::lower_bound(poses_.begin(), poses_.end(), from, before);
  auto hi = std::upper_bound(poses_.begin(), poses_.end(), to, after);
  // Two before and one after: the bracketing poses and, where the sweep reaches beyond the poses, a pair for the
  // velocity to extrapolate with.
  lo -= std::min<std::ptrdiff_t>(2, lo - poses_.begin());
  hi += std::min<std::ptrdiff_t>(1, poses_.end() - hi);
  return {lo, hi};
}

bool ScanPoseAssociator::sweep_ready(const Pending& p, double wall_time_s, bool use_wall_clock) const {
  if (!sweep_poses_) return true;
  // A sweep that reaches back before the oldest pose (the drive's first scan, stamped at the sweep's end) is deskewed
  // by extrapolating backwards at the velocity of the first pose pair: it waits for a second pose.
  const bool needs_velocity = p.sweep_begin < p.utime && poses_.size() == 1 && poses_.front().utime > p.sweep_begin;
  if (p.sweep_end <= p.utime && !needs_velocity) return true;  // a pose at utime is all a resolvable scan needs
  const std::int64_t newest = poses_.empty() ? INT64_MIN : poses_.back().utime;
  if (newest >= p.sweep_end && !needs_velocity) return true;
  // The data clock runs on with scans too (odometry may have stopped); deskew extrapolates or skips what is missing.
  const std::int64_t data_now = std::max(newest, last_scan_utime_.value_or(p.utime));
  const bool data_timeout = data_now - p.utime > static_cast<std::int64_t>(config_.hold_time * 1e6);
  const bool wall_timeout = use_wall_clock && wall_time_s - p.arrival_wall_s > config_.hold_time;
  return data_timeout || wall_timeout;
}

std::optional<AssociatedScan> ScanPoseAssociator::resolve(Pending& p) {
  auto pose = pose_at(p.utime);
  if (!pose) return std::nullopt;
  AssociatedScan s;
  if (sweep_poses_ && p.cloud.has_time()) s.sweep_poses = poses_around(std::min(p.sweep_begin, p.utime), std::max(p.sweep_end, p.utime));
  s.utime = p.utime;
  s.sweep_begin = p.sweep_begin;
  s.sweep_end = p.sweep_end;
  s.cloud = std::move(p.cloud);
  s.pose = *pose;
  s.residual_sum = last_resolved_utime_ ? residual_between(*last_resolved_utime_, p.utime) : pose->residual;
  last_resolved_utime_ = p.utime;
  return s;
}

std::vector<AssociatedScan> ScanPoseAssociator::poll(double wall_time_s, bool use_wall_clock) {
  std::vector<AssociatedScan> out;
  const auto hold = static_cast<std::int64_t>(config_.hold_time * 1e6);
  const auto tol = static_cast<std::int64_t>(config_.tolerance * 1e6);
  while (!scans_.empty()) {
    Pending& p = scans_.front();
    if (!sweep_ready(p, wall_time_s, use_wall_clock)) break;  // keep order: later scans wait behind this one
    if (auto s = resolve(p)) {
      out.push_back(std::move(*s));
      scans_.pop_front();
      continue;
    }
    const std::int64_t newest = poses_.empty() ? INT64_MIN : poses_.back().utime;
    // Give up when poses have moved past the scan without bracketing it, when data time has run past the hold
    // time, or (live) when the scan has waited longer than the hold time on the wall clock.
    const bool passed = newest != INT64_MIN && newest >= p.utime + tol;
    const bool data_timeout = newest != INT64_MIN && newest - p.utime > hold;
    const bool wall_timeout = use_wall_clock && wall_time_s - p.arrival_wall_s > config_.hold_time;
    if (passed || data_timeout || wall_timeout) {
      ++dropped_no_pose_;
      scans_.pop_front();
      continue;
    }
    break;  // keep order: later scans wait behind this one
  }
  return out;
}

std::vector<AssociatedScan> ScanPoseAssociator::flush() {
  std::vector<AssociatedScan> out;
  while (!scans_.empty()) {
    if (auto s = resolve(scans_.front()))
      out.push_back(std::move(*s));
    else
      ++dropped_no_pose_;
    scans_.pop_front();
  }
  return out;
}

}  // namespace loopd
