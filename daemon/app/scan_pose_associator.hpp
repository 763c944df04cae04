#pragma once
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "loopd/core/point_cloud.hpp"
#include "loopd/core/pose.hpp"

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
};

/// @brief Pairs scans with poses by utime: an exact match, or slerp between the bracketing poses when both lie
///        within the tolerance. Scans wait at most hold_time for their poses, then are dropped and counted.
///        Not thread-safe (used by the one ingest thread).
class ScanPoseAssociator {
 public:
  explicit ScanPoseAssociator(const AssociationConfig& config) : config_(config) {}

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
  };
  std::optional<AssociatedScan> resolve(Pending& p);
  double residual_between(std::int64_t from, std::int64_t to) const;

  AssociationConfig config_;
  std::deque<StampedPose> poses_;
  std::deque<Pending> scans_;
  std::optional<std::int64_t> last_scan_utime_;
  std::optional<std::int64_t> last_resolved_utime_;
  std::int64_t dropped_no_pose_ = 0;
  std::int64_t rejected_pose_order_ = 0;
  std::int64_t rejected_scan_order_ = 0;
};

}  // namespace loopd
