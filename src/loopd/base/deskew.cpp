#include "loopd/base/deskew.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace loopd {
namespace {
constexpr double kUtimeResolution = 1e-6;  ///< [s] poses are stamped in microseconds: closer than this is not beyond them
}  // namespace

std::optional<std::string> DeskewConfig::validate() const {
  // Per-point times lie within +-1 s of the stamp (point_cloud_t, bounded_decode): a sweep spans at most 2 s.
  if (!(max_sweep > 0.0 && max_sweep <= 2.0)) return "deskew.max_sweep must be > 0 and <= 2 [s]";
  if (!(max_extrapolation >= 0.0 && max_extrapolation <= 2.0)) return "deskew.max_extrapolation must be >= 0 and <= 2 [s]";
  if (!(max_pose_gap > 0.0 && max_pose_gap <= 10.0)) return "deskew.max_pose_gap must be > 0 and <= 10 [s]";
  if (time_bins < 0 || time_bins > 100000) return "deskew.time_bins must be >= 0 and <= 100000 (0 = every point's own pose)";
  return std::nullopt;
}

const char* to_string(DeskewSkip skip) {
  switch (skip) {
    case DeskewSkip::kNone:
      return "deskewed";
    case DeskewSkip::kDisabled:
      return "disabled";
    case DeskewSkip::kNoTimes:
      return "no per-point times";
    case DeskewSkip::kNoSpan:
      return "every point time is 0";
    case DeskewSkip::kSweepTooLong:
      return "point times span more than deskew.max_sweep";
    case DeskewSkip::kPosesDoNotCover:
      return "the poses do not cover the sweep";
  }
  return "unknown";
}

PoseTrack::PoseTrack(const std::vector<StampedPose>& poses, std::int64_t origin_utime, double max_pose_gap) : max_gap_(max_pose_gap) {
  times_.reserve(poses.size());
  poses_.reserve(poses.size());
  for (const StampedPose& p : poses) {
    times_.push_back(static_cast<double>(p.utime - origin_utime) / 1e6);
    poses_.push_back(p.T_world_sensor);
  }
}

std::optional<Eigen::Isometry3d> PoseTrack::at(double t, double max_extrapolation, double* extrapolated) const {
  if (extrapolated) *extrapolated = 0.0;
  const std::size_t n = times_.size();
  const std::size_t k = static_cast<std::size_t>(std::lower_bound(times_.begin(), times_.end(), t) - times_.begin());
  if (k < n && times_[k] == t) return poses_[k];
  if (n < 2) return std::nullopt;
  std::size_t a = k - 1, b = k;
  double beyond = 0.0;
  if (k == 0) {
    a = 0, b = 1, beyond = times_[0] - t;
  } else if (k == n) {
    a = n - 2, b = n - 1, beyond = t - times_[n - 1];
  }
  const double span = times_[b] - times_[a];
  if (beyond > max_extrapolation + kUtimeResolution || span > max_gap_) return std::nullopt;
  if (extrapolated && beyond > kUtimeResolution) *extrapolated = beyond;
  // The screw motion between the pair (a constant velocity in the sensor frame: an arc stays an arc); with alpha
  // outside [0, 1] it continues the same motion.
  return interpolate_screw(poses_[a], poses_[b], (t - times_[a]) / span);
}

std::optional<double> PoseTrack::coverage(double lo, double hi, double max_extrapolation) const {
  double before = 0.0, after = 0.0;
  if (!at(lo, max_extrapolation, &before) || !at(hi, max_extrapolation, &after)) return std::nullopt;
  for (std::size_t k = 0; k + 1 < times_.size(); ++k)
    if (times_[k + 1] > lo && times_[k] < hi && times_[k + 1] - times_[k] > max_gap_) return std::nullopt;
  return std::max(before, after);
}

std::pair<double, double> time_span(const PointCloud& cloud) {
  // Eight running minima and maxima without a branch (a time that is not finite gives +inf / -inf), so the compiler
  // vectorises the loop: it runs on every scan.
  constexpr std::size_t kLanes = 8;
  constexpr float kInf = std::numeric_limits<float>::infinity(), kMax = std::numeric_limits<float>::max();
  float lo[kLanes], hi[kLanes];
  std::fill(lo, lo + kLanes, kInf);
  std::fill(hi, hi + kLanes, -kInf);
  const float* t = cloud.time.data();
  const std::size_t n = cloud.time.size(), whole = n / kLanes * kLanes;
  for (std::size_t i = 0; i < whole; i += kLanes)
    for (std::size_t k = 0; k < kLanes; ++k) {
      const float v = t[i + k];
      const bool finite = std::abs(v) <= kMax;  // false for NaN and +-inf
      lo[k] = std::min(lo[k], finite ? v : kInf);
      hi[k] = std::max(hi[k], finite ? v : -kInf);
    }
  for (std::size_t i = whole; i < n; ++i) {
    const bool finite = std::abs(t[i]) <= kMax;
    lo[0] = std::min(lo[0], finite ? t[i] : kInf);
    hi[0] = std::max(hi[0], finite ? t[i] : -kInf);
  }
  const float first = *std::min_element(lo, lo + kLanes), last = *std::max_element(hi, hi + kLanes);
  if (first > last) return {0.0, 0.0};
  return {first, last};
}

namespace {

/// Moves point i to `moved` and keeps the result's counters.
void move_point(PointCloud* cloud, std::size_t i, const Eigen::Vector3f& moved, DeskewResult* r) {
  Eigen::Vector3f& p = cloud->points[i];
  if (moved == p) return;
  ++r->points_moved;
  r->max_correction = std::max(r->max_correction, static_cast<double>((moved - p).norm()));
  p = moved;
}

bool deskewable(const PointCloud& cloud, std::size_t i) { return std::isfinite(cloud.time[i]) && cloud.points[i].allFinite(); }

/// T_stamp_point(t): the sensor frame at time t [s after the stamp] in the sensor frame at the stamp.
using RelativeMotion = std::function<Eigen::Isometry3d(double)>;

/// Every point with the sensor pose at its own time (the reference; one pose per distinct time).
void deskew_exact(const RelativeMotion& T_stamp_at, PointCloud* cloud, DeskewResult* r) {
  float last_time = std::numeric_limits<float>::quiet_NaN();
  Eigen::Isometry3d T_stamp_point = Eigen::Isometry3d::Identity();
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    if (!deskewable(*cloud, i)) continue;
    if (!(cloud->time[i] == last_time)) {
      last_time = cloud->time[i];
      T_stamp_point = T_stamp_at(last_time);
    }
    move_point(cloud, i, (T_stamp_point * cloud->points[i].cast<double>()).cast<float>(), r);
  }
}

/// Sensor poses at bins + 1 instants over [t0, t1]; each point blends the images under its two neighbouring instants
/// (within a pose segment translation is linear in time and rotation nearly so: the blend's error is second order).
void deskew_binned(const RelativeMotion& T_stamp_at, double t0, double t1, int bins, PointCloud* cloud, DeskewResult* r) {
  std::vector<Eigen::Matrix3f> R(static_cast<std::size_t>(bins) + 1);
  std::vector<Eigen::Vector3f> t(R.size());
  const double width = (t1 - t0) / bins;
  for (std::size_t k = 0; k < R.size(); ++k) {
    const Eigen::Isometry3d T = T_stamp_at(k + 1 == R.size() ? t1 : t0 + width * static_cast<double>(k));
    R[k] = T.linear().cast<float>();
    t[k] = T.translation().cast<float>();
  }
  const double scale = bins / (t1 - t0);
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    if (!deskewable(*cloud, i)) continue;
    const double u = std::clamp((cloud->time[i] - t0) * scale, 0.0, static_cast<double>(bins));
    const std::size_t k = std::min(static_cast<std::size_t>(u), static_cast<std::size_t>(bins) - 1);
    const float a = static_cast<float>(u - static_cast<double>(k));
    const Eigen::Vector3f& p = cloud->points[i];
    move_point(cloud, i, (1.0f - a) * (R[k] * p + t[k]) + a * (R[k + 1] * p + t[k + 1]), r);
  }
}

}  // namespace

DeskewResult deskew(const DeskewConfig& config, const std::vector<StampedPose>& poses, std::int64_t utime, PointCloud* cloud) {
  DeskewResult r;
  const auto skip = [&r](DeskewSkip why) {
    r.skipped = why;
    return r;
  };
  if (!config.enabled) return skip(DeskewSkip::kDisabled);
  if (!cloud->has_time()) return skip(DeskewSkip::kNoTimes);
  const auto [t0, t1] = time_span(*cloud);
  r.sweep = t1 - t0;
  if (t0 == 0.0 && t1 == 0.0) return skip(DeskewSkip::kNoSpan);
  if (r.sweep > config.max_sweep) return skip(DeskewSkip::kSweepTooLong);
  const PoseTrack track(poses, utime, config.max_pose_gap);
  // The stamp (time 0) is covered too: the points move into the sensor frame there.
  const auto extrapolated = track.coverage(std::min(t0, 0.0), std::max(t1, 0.0), config.max_extrapolation);
  if (!extrapolated) return skip(DeskewSkip::kPosesDoNotCover);
  r.extrapolated = *extrapolated;
  const Eigen::Isometry3d T_odom_stamp = *track.at(0.0, config.max_extrapolation);
  const double reach = config.max_extrapolation;
  const RelativeMotion T_stamp_at = [&track, T_stamp_odom = T_odom_stamp.inverse(), reach](double t) {
    return T_stamp_odom * *track.at(t, reach);  // covered: checked above
  };
  if (config.time_bins > 0 && r.sweep > 0.0)
    deskew_binned(T_stamp_at, t0, t1, config.time_bins, cloud, &r);
  else
    deskew_exact(T_stamp_at, cloud, &r);
  return r;
}

}  // namespace loopd
