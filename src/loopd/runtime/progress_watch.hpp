#pragma once
/// @file Pipeline liveness as seen from outside: per-stage progress counters and the rule that says a stage stalled.
#include <cstdint>
#include <string>

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

}  // namespace loopd
