#pragma once
#include <cstdint>
#include <deque>

namespace loopd {

/// @brief Estimates scans that never reached loopd. LCM drops a whole message when one of its UDP fragments is
///        lost (an HDL-64E scan is ~1,600 fragments), so a lost scan is never received and never counted anywhere.
///        A spinning lidar publishes at a steady rate, so a gap of k scan periods between two received scans means
///        k - 1 scans were lost. The period is a low quantile (20th percentile) of the last intervals, which stays
///        the true period even when half the scans are lost. Odometry still arriving after the last scan counts the
///        scans that should have come meanwhile (pending until the next scan or the end).
class ScanLossEstimator {
 public:
  struct Config {
    int window = 64;             ///< intervals kept for the period estimate
    int min_intervals = 8;       ///< no estimate before this many intervals
    double gap_factor = 1.5;     ///< an interval above gap_factor x period is a gap
    double max_gap_s = 30.0;     ///< longer gaps are outages (sensor off), not loss: not counted
  };
  ScanLossEstimator() = default;
  explicit ScanLossEstimator(const Config& config) : config_(config) {}

  /// @brief A received scan at `utime` [us]. `clock_jumped` when the data clock jumped just before it (no gap).
  void on_scan(std::int64_t utime, bool clock_jumped = false);
  /// @brief An odometry pose at `utime` [us] (shows how far data time has gone without scans).
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

  Config config_;
  std::deque<std::int64_t> intervals_;
  std::int64_t period_us_ = 0;
  std::int64_t last_scan_ = 0;
  bool has_last_ = false;
  std::int64_t newest_pose_ = 0;
  std::int64_t lost_ = 0;
  std::int64_t received_ = 0;
};

}  // namespace loopd
