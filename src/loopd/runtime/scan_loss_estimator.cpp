#include "loopd/runtime/scan_loss_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace loopd {
namespace {
void push_window(std::deque<std::int64_t>* window, std::int64_t v, int size) {
  window->push_back(v);
  if (static_cast<int>(window->size()) > size) window->pop_front();
}

/// 20th percentile of a window (robust to lost messages, which only lengthen intervals).
std::int64_t low_quantile(const std::deque<std::int64_t>& window) {
  std::vector<std::int64_t> sorted(window.begin(), window.end());
  const std::size_t k = sorted.size() / 5;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
  return sorted[k];
}
}  // namespace

std::int64_t ScanLossEstimator::missing_in(std::int64_t gap_us) const {
  if (period_us_ <= 0 || gap_us <= static_cast<std::int64_t>(config_.gap_factor * static_cast<double>(period_us_)) ||
      gap_us > static_cast<std::int64_t>(config_.max_gap_s * 1e6))
    return 0;
  return std::max<std::int64_t>(0, std::llround(static_cast<double>(gap_us) / static_cast<double>(period_us_)) - 1);
}

void ScanLossEstimator::on_scan(std::int64_t utime, bool clock_jumped) {
  ++received_;
  if (has_scan_ && !clock_jumped && utime > last_scan_) {
    const std::int64_t gap = utime - last_scan_;
    push_window(&scan_intervals_, gap, config_.window);
    update_period();
    if (period_us_ > 0) {
      const std::int64_t missing = missing_in(gap);
      lost_ += missing;
      if (missing > 0) remember_gap(last_scan_, utime, missing);
    } else if (static_cast<int>(uncounted_.size()) < config_.window) {
      uncounted_.push_back(gap);
    }
  }
  if (!has_scan_ || clock_jumped || utime > last_scan_) last_scan_ = utime;
  if (!has_scan_) first_scan_ = utime;
  has_scan_ = true;
  if (clock_jumped) newest_pose_ = utime;
}

void ScanLossEstimator::remember_gap(std::int64_t start, std::int64_t end, std::int64_t missing) {
  recent_gaps_.push_back({start, end, missing, {}});
  if (recent_gaps_.size() > 16) recent_gaps_.pop_front();
}

void ScanLossEstimator::on_late_scan(std::int64_t utime) {
  for (Gap& g : recent_gaps_) {
    if (utime <= g.start || utime >= g.end || g.missing == 0) continue;
    if (std::find(g.late.begin(), g.late.end(), utime) != g.late.end()) return;  // a copy of a late scan
    g.late.push_back(utime);
    --g.missing;
    --lost_;
    ++received_;
    return;
  }
}

void ScanLossEstimator::on_pose(std::int64_t utime, bool clock_jumped) {
  if (has_pose_ && !clock_jumped && utime > last_pose_) push_window(&pose_intervals_, utime - last_pose_, config_.window);
  if (!has_pose_ || clock_jumped || utime > last_pose_) last_pose_ = utime;
  if (!has_pose_ && !has_scan_) {
    first_pose_ = utime;
    pose_before_scan_ = true;
  }
  has_pose_ = true;
  newest_pose_ = clock_jumped ? utime : std::max(newest_pose_, utime);
}

void ScanLossEstimator::update_period() {
  if (static_cast<int>(scan_intervals_.size()) < config_.min_intervals) return;
  std::int64_t period = 0;
  if (static_cast<int>(pose_intervals_.size()) >= config_.min_intervals) {
    // Scan intervals in pose periods; their greatest common divisor is the scan period in pose periods.
    const std::int64_t pose_period = low_quantile(pose_intervals_);
    std::int64_t divisor = 0;
    int aligned = 0;
    for (std::int64_t interval : scan_intervals_) {
      const double n = static_cast<double>(interval) / static_cast<double>(pose_period);
      const auto rounded = std::llround(n);
      if (rounded < 1 || std::abs(n - static_cast<double>(rounded)) > 0.25) continue;  // not on the pose grid
      divisor = std::gcd(divisor, static_cast<std::int64_t>(rounded));
      ++aligned;
    }
    if (pose_period > 0 && divisor > 0 && aligned * 5 >= static_cast<int>(scan_intervals_.size()) * 4) period = divisor * pose_period;
  }
  if (period == 0) period = low_quantile(scan_intervals_);  // no usable odometry rate
  const bool first = period_us_ == 0;
  period_us_ = period;
  if (first) {
    for (std::int64_t gap : uncounted_) lost_ += missing_in(gap);
    uncounted_.clear();
    // Odometry that ran before the first scan arrived: the scans due meanwhile were lost too.
    const std::int64_t head = first_scan_ - first_pose_;
    if (pose_before_scan_ && head >= period_us_ && head <= static_cast<std::int64_t>(config_.max_gap_s * 1e6)) lost_ += head / period_us_;
  }
}

std::int64_t ScanLossEstimator::lost() const {
  std::int64_t pending = 0;
  if (has_scan_ && period_us_ > 0) {
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
