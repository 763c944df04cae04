#pragma once
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief How scans find their odometry pose.
struct AssociationConfig {
  double tolerance = 0.1;      ///< [s] max time between a scan and each bracketing pose (0.1 s = one 10 Hz period)
  double hold_time = 1.0;      ///< [s] how long a scan may wait for its poses (data time; wall time too when live)
  int max_pending_scans = 32;  ///< scans waiting for a pose; the oldest is dropped beyond this
  int max_poses = 4096;        ///< poses kept for interpolation (oldest trimmed)
  std::optional<std::string> validate() const;
};

/// @brief A scan with the odometry pose at its time.
struct AssociatedScan {
  std::int64_t utime = 0;
  PointCloud cloud;
  StampedPose pose;           ///< T_odom_sensor at utime (exact or interpolated)
  double residual_sum = 0.0;  ///< sum of pose residuals since the previous associated scan [m]
  /// With sweep poses on and per-point times in the cloud: the poses around the sweep (the ones within it, two before
  /// and one after it where the associator holds them), for deskew; empty otherwise.
  std::vector<StampedPose> sweep_poses;
  /// [us] the first and last point time with sweep poses on and per-point times in the cloud; utime otherwise.
  std::int64_t sweep_begin = 0, sweep_end = 0;
};

/// @brief Pairs scans with poses by utime: an exact match, or slerp between the bracketing poses when both lie
///        within the tolerance. Scans wait at most hold_time for their poses, then are dropped and counted.
///        With sweep poses on, a scan with per-point times also waits (at most hold_time, in data time or live on the
///        wall clock) for a pose at or after its last point time, and leaves with the poses around its sweep.
///        Not thread-safe (used by the one ingest thread).
class ScanPoseAssociator {
 public:
  /// @param sweep_poses scans with per-point times wait for their sweep's poses and leave with them (for deskew).
  explicit ScanPoseAssociator(const AssociationConfig& config, bool sweep_poses = false) : config_(config), sweep_poses_(sweep_poses) {}

  /// @brief Adds a pose; returns false (and counts it) for a duplicate or out-of-order utime.
  bool add_pose(const StampedPose& pose);
  /// @brief Adds a scan; returns false (and counts it) for a duplicate or out-of-order utime.
  bool add_scan(std::int64_t utime, PointCloud cloud, double wall_time_s);
  /// @brief The scan clock jumped back: pending scans can never be resolved (counted as without pose), and the
  ///        next scan starts a new timeline.
  void restart_scans();
  /// @brief The pose clock jumped back: poses of the old timeline are forgotten.
  void restart_poses();
  /// @brief Scans that can be resolved now (in utime order). Drops scans that can no longer be.
  std::vector<AssociatedScan> poll(double wall_time_s, bool use_wall_clock);
  /// @brief At end of input: resolves what can be, drops the rest.
  std::vector<AssociatedScan> flush();

  std::int64_t dropped_no_pose() const { return dropped_no_pose_; }
  std::int64_t rejected_pose_order() const { return rejected_pose_order_; }
  std::int64_t rejected_scan_order() const { return rejected_scan_order_; }
  std::size_t pending() const { return scans_.size(); }

  /// @brief Pose at `utime` by exact match or interpolation, if the bracketing poses allow it.
  std::optional<StampedPose> pose_at(std::int64_t utime) const;

 private:
  struct Pending {
    std::int64_t utime;
    PointCloud cloud;
    double arrival_wall_s;
    std::int64_t sweep_begin, sweep_end;  ///< [us] first and last point time (utime when the scan has no times)
  };
  std::optional<AssociatedScan> resolve(Pending& p);
  /// Whether `p` may leave: its sweep's last pose is there, or it has waited hold_time (always without sweep poses).
  bool sweep_ready(const Pending& p, double wall_time_s, bool use_wall_clock) const;
  std::vector<StampedPose> poses_around(std::int64_t from, std::int64_t to) const;
  double residual_between(std::int64_t from, std::int64_t to) const;

  AssociationConfig config_;
  bool sweep_poses_ = false;
  std::deque<StampedPose> poses_;
  std::deque<Pending> scans_;
  std::optional<std::int64_t> last_scan_utime_;
  std::optional<std::int64_t> last_resolved_utime_;
  std::int64_t dropped_no_pose_ = 0;
  std::int64_t rejected_pose_order_ = 0;
  std::int64_t rejected_scan_order_ = 0;
};

}  // namespace loopd
