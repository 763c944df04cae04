#pragma once
/// @file Pipeline liveness for the systemd watchdog: WATCHDOG=1 only while every stage makes progress.
#include <cstdint>
#include <string>
#include <vector>

#include "systemd_notify.hpp"

namespace loopd {

/// @brief Progress of one pipeline stage as seen from outside: a counter that moves whenever the stage finishes a
/// piece of work, and whether work waits for the stage.
struct StageProgress {
  std::int64_t steps = 0;
  bool pending = false;
};

/// @brief Decides whether one stage is alive: it is while nothing waits for it (idle is alive: a parked vehicle
/// sends nothing) or while its step counter moved within the last stall_s seconds.
class ProgressWatch {
 public:
  explicit ProgressWatch(double stall_s) : stall_s_(stall_s) {}
  /// @brief One observation at `now_s` (any monotonic clock); returns whether the stage is alive.
  bool update(const StageProgress& progress, double now_s);
  /// @brief [s] how long work has waited without the counter moving (0 when alive and moving, or idle).
  double stalled_for(double now_s) const { return now_s - last_progress_s_; }

 private:
  double stall_s_;
  bool seen_ = false;
  std::int64_t last_steps_ = 0;
  double last_progress_s_ = 0.0;
};

/// @brief The watched stages of loopd, by name, in the order they are polled.
struct NamedProgress {
  std::string name;
  StageProgress progress;
};

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
