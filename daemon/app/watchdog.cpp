#include "watchdog.hpp"

#include <cstdio>

#include "loopd/runtime/log_level.hpp"

namespace loopd {

bool PipelineWatchdog::poll(const std::vector<NamedProgress>& stages, double now_s) {
  if (watches_.size() != stages.size()) watches_.assign(stages.size(), ProgressWatch(stall_s_));
  const NamedProgress* stuck = nullptr;
  double stuck_for = 0.0;
  for (std::size_t i = 0; i < stages.size(); ++i) {
    if (!watches_[i].update(stages[i].progress, now_s) && !stuck) {
      stuck = &stages[i];
      stuck_for = watches_[i].stalled_for(now_s);
    }
  }
  if (stuck && !stalled_ && log_enabled(LogLevel::kWarn))
    std::fprintf(stderr, "loopd: the %s made no progress for %.1f s with work waiting%s\n", stuck->name.c_str(), stuck_for,
                 notifier_.ping_interval_s() > 0.0 ? ": watchdog pings stop (systemd restarts loopd)" : "");
  if (!stuck && stalled_ && log_enabled(LogLevel::kWarn))
    std::fprintf(stderr, "loopd: the pipeline makes progress again%s\n", notifier_.ping_interval_s() > 0.0 ? ": watchdog pings resume" : "");
  stalled_ = stuck != nullptr;
  if (stalled_ || notifier_.ping_interval_s() <= 0.0 || now_s < next_ping_s_) return !stalled_;
  notifier_.watchdog();
  ++pings_;
  next_ping_s_ = now_s + notifier_.ping_interval_s();
  return true;
}

}  // namespace loopd
