#pragma once
#include <cstdint>
#include <deque>
#include <vector>

namespace loopd {

/// @brief Estimates scans that never reached loopd. LCM drops a whole message when one of its UDP fragments is
///        lost (an HDL-64E scan is ~1,600 fragments), so a lost scan is never received and never counted anywhere.
///        A spinning lidar publishes at a steady rate, so a gap of k scan periods between two received scans means
///        k - 1 scans were lost. The scan period comes from the odometry, which is small and rarely lost: the scan
///        period is the pose period times the greatest common divisor of the scan intervals counted in pose periods
///        (odometry at the scan rate: 1; 100 Hz odometry and a 10 Hz lidar: 10), which holds even when 95 % of the
///        scans are lost. Without odometry, a low quantile (20th percentile) of the scan intervals. Odometry still
///        arriving after the last scan counts the scans that should have come meanwhile (pending until the next scan).
class ScanLossEstimator {
 public:
  struct Config {
    int window = 64;          ///< intervals kept for the period estimates
    int min_intervals = 5;    ///< no estimate before this many scan intervals
    double gap_factor = 1.5;  ///< an interval above gap_factor x period is a gap
    double max_gap_s = 30.0;  ///< longer gaps are outages (sensor off), not loss: not counted
  };
  ScanLossEstimator() = default;
  explicit ScanLossEstimator(const Config& config) : config_(config) {}

  /// @brief A received scan at `utime` [us]. `clock_jumped` when the data clock jumped just before it (no gap).
  void on_scan(std::int64_t utime, bool clock_jumped = false);
  /// @brief A scan that arrived after a newer one (rejected as stale): if it falls inside a recent gap counted as
  ///        loss, it was late, not lost, and is taken back off the count (each utime once).
  void on_late_scan(std::int64_t utime);
  /// @brief An odometry pose at `utime` [us]. `clock_jumped` as for scans.
  void on_pose(std::int64_t utime, bool clock_jumped = false);
  /// @brief Lost scans so far, including those pending since the last scan.
  std::int64_t lost() const;
  std::int64_t received() const { return received_; }
  /// @brief lost / (received + lost); 0 before anything was received.
  double loss_fraction() const;
  /// @brief Estimated scan period [us]; 0 while unknown.
  std::int64_t period_us() const { return period_us_; }

 private:
  void update_period();
  void remember_gap(std::int64_t start, std::int64_t end, std::int64_t missing);
  std::int64_t missing_in(std::int64_t gap_us) const;

  Config config_;
  std::deque<std::int64_t> scan_intervals_, pose_intervals_;
  struct Gap {
    std::int64_t start, end, missing;
    std::vector<std::int64_t> late;  ///< utimes of late scans already taken back
  };
  std::deque<Gap> recent_gaps_;          ///< the last gaps counted as loss (late scans are looked up here)
  std::vector<std::int64_t> uncounted_;  ///< gaps seen before the period was known (counted once it is)
  std::int64_t period_us_ = 0;
  std::int64_t first_scan_ = 0, first_pose_ = 0;  ///< scans due between the first pose and the first scan are lost too
  std::int64_t last_scan_ = 0, last_pose_ = 0, newest_pose_ = 0;
  bool has_scan_ = false, has_pose_ = false, pose_before_scan_ = false;
  std::int64_t lost_ = 0;
  std::int64_t received_ = 0;
};

}  // namespace loopd
