#pragma once
#include <cstdint>
#include <optional>

namespace loopd {

/// @brief Verdict on one message's data time (its utime) against the channel's timeline.
enum class ClockVerdict {
  kInOrder,      ///< newer than the last message: accept
  kStale,        ///< duplicate or older (reordered, repeated): reject and count
  kJumpForward,  ///< newer, but the data clock ran ahead of the arrival clock by more than the jump threshold: accept
  kJumpBack,     ///< a confirmed backward jump: accept, the channel follows the new timeline
};

/// @brief Follows one input channel's data clock against the arrival clock (the wall clock live, the logger's
///        receive time in replay). A message older than the last one is normally stale (a duplicate or a reordered
///        UDP datagram) and rejected. But when the data clock jumped back (a GPS/NTP time step, a restarted
///        publisher, a log spliced from two drives), every later message would be "older" and the channel would be
///        dead for good; so when `confirm` consecutive messages are older by more than `jump_s`, in order among
///        themselves, the channel follows them. A single bogus far-future utime is undone the same way.
class ClockWatch {
 public:
  struct Config {
    double jump_s = 2.0;  ///< [s] disagreement between data and arrival clocks that counts as a jump
    int confirm = 2;      ///< consecutive far-older messages that confirm a backward jump
  };
  ClockWatch() = default;
  explicit ClockWatch(const Config& config) : config_(config) {}

  /// @brief Classifies a message stamped `utime` [us] that arrived at `arrival_s` [s]; accepted ones become the last.
  ClockVerdict check(std::int64_t utime, double arrival_s);
  std::int64_t jumps() const { return jumps_; }
  std::optional<std::int64_t> last_utime() const { return last_utime_; }

 private:
  Config config_;
  std::optional<std::int64_t> last_utime_;
  double last_arrival_s_ = 0.0;
  int far_older_ = 0;                ///< consecutive messages older than the last by more than jump_s
  std::int64_t far_older_last_ = 0;  ///< utime of the latest of them
  std::int64_t jumps_ = 0;
};

}  // namespace loopd
