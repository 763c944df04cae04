#include "loopd/runtime/clock_watch.hpp"

namespace loopd {

ClockVerdict ClockWatch::check(std::int64_t utime, double arrival_s) {
  if (!last_utime_) {
    last_utime_ = utime;
    last_arrival_s_ = arrival_s;
    return ClockVerdict::kInOrder;
  }
  // Differences in long double: utimes are hostile and may be anywhere in int64.
  const long double data_s = (static_cast<long double>(utime) - static_cast<long double>(*last_utime_)) * 1e-6L;
  const long double arrival_delta_s = static_cast<long double>(arrival_s) - static_cast<long double>(last_arrival_s_);
  const long double skew_s = data_s - arrival_delta_s;  // > 0: data clock ran ahead of arrivals
  if (utime > *last_utime_) {
    far_older_ = 0;
    last_utime_ = utime;
    last_arrival_s_ = arrival_s;
    if (skew_s > config_.jump_s) {
      ++jumps_;
      return ClockVerdict::kJumpForward;
    }
    return ClockVerdict::kInOrder;
  }
  if (utime == *last_utime_ || -skew_s <= config_.jump_s) {
    far_older_ = 0;
    return ClockVerdict::kStale;  // a duplicate or a datagram a little out of order
  }
  // Far older than the timeline: the start of a backward jump, or one bogus stamp. Confirm before following.
  if (far_older_ > 0 && utime <= far_older_last_) far_older_ = 0;  // not in order among themselves
  ++far_older_;
  far_older_last_ = utime;
  if (far_older_ < config_.confirm) return ClockVerdict::kStale;
  far_older_ = 0;
  last_utime_ = utime;
  last_arrival_s_ = arrival_s;
  ++jumps_;
  return ClockVerdict::kJumpBack;
}

}  // namespace loopd
