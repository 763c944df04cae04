#pragma once
/// @file Pipeline liveness for the systemd watchdog: WATCHDOG=1 only while every stage makes progress.
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/runtime/progress_watch.hpp"
#include "systemd_notify.hpp"

namespace loopd {

/// @brief Sends WATCHDOG=1 at the notifier's ping interval while every stage is alive. When a stage stalls the pings
/// stop (systemd restarts loopd after WatchdogSec=), with one log line naming the stage; one more when they resume.
/// poll() is called from the loop that handles LCM, so pings also stop when that loop stops.
class PipelineWatchdog {
 public:
  PipelineWatchdog(SystemdNotifier& notifier, double stall_s) : notifier_(notifier), stall_s_(stall_s) {}
  /// @brief One poll at `now_s`; `stages` in the same order on every call. Returns whether every stage is alive.
  bool poll(const std::vector<NamedProgress>& stages, double now_s);
  /// @brief Pings sent so far.
  std::int64_t pings() const { return pings_; }

 private:
  SystemdNotifier& notifier_;
  double stall_s_;
  std::vector<ProgressWatch> watches_;
  double next_ping_s_ = 0.0;
  bool stalled_ = false;
  std::int64_t pings_ = 0;
};

}  // namespace loopd
