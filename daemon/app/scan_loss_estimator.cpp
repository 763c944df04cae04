#include "scan_loss_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace loopd {
namespace {
/// Scans missing in a gap of `gap_us` at `period_us`: round(gap / period) - 1.
std::int64_t missing_in_gap(std::int64_t gap_us, std::int64_t period_us) {
  return std::max<std::int64_t>(0, std::llround(static_cast<double>(gap_us) / static_cast<double>(period_us)) - 1);
}
}  // namespace

void ScanLossEstimator::on_scan(std::int64_t utime, bool clock_jumped) {
  ++received_;
  if (has_last_ && !clock_jumped && utime > last_scan_) {
    const std::int64_t gap = utime - last_scan_;
    if (period_us_ > 0 && gap > static_cast<std::int64_t>(config_.gap_factor * static_cast<double>(period_us_)) &&
        gap <= static_cast<std::int64_t>(config_.max_gap_s * 1e6))
      lost_ += missing_in_gap(gap, period_us_);
    intervals_.push_back(gap);
    if (static_cast<int>(intervals_.size()) > config_.window) intervals_.pop_front();
    update_period();
  }
  if (!has_last_ || clock_jumped || utime > last_scan_) last_scan_ = utime;
  if (clock_jumped) newest_pose_ = utime;
  has_last_ = true;
}

void ScanLossEstimator::on_pose(std::int64_t utime, bool clock_jumped) { newest_pose_ = clock_jumped ? utime : std::max(newest_pose_, utime); }

void ScanLossEstimator::update_period() {
  if (static_cast<int>(intervals_.size()) < config_.min_intervals) return;
  std::vector<std::int64_t> sorted(intervals_.begin(), intervals_.end());
  const std::size_t k = sorted.size() / 5;  // 20th percentile
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
  period_us_ = sorted[k];
}

std::int64_t ScanLossEstimator::lost() const {
  std::int64_t pending = 0;
  if (has_last_ && period_us_ > 0) {
    const std::int64_t since = newest_pose_ - last_scan_;  // odometry went on without scans
    if (since > static_cast<std::int64_t>(config_.gap_factor * static_cast<double>(period_us_)) &&
        since <= static_cast<std::int64_t>(config_.max_gap_s * 1e6))
      pending = since / period_us_;  // scans due at last + k * period <= newest pose
  }
  return lost_ + pending;
}

double ScanLossEstimator::loss_fraction() const {
  const std::int64_t l = lost();
  return received_ + l > 0 ? static_cast<double>(l) / static_cast<double>(received_ + l) : 0.0;
}

}  // namespace loopd
