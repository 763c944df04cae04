#include "loopd/runtime/progress_watch.hpp"

namespace loopd {

bool ProgressWatch::update(const StageProgress& progress, double now_s) {
  if (!seen_ || !progress.pending || progress.steps != last_steps_) {
    seen_ = true;
    last_steps_ = progress.steps;
    last_progress_s_ = now_s;
  }
  return now_s - last_progress_s_ <= stall_s_;
}

}  // namespace loopd
