#include "loopd/base/thread_priority.hpp"

#include <algorithm>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace loopd {

bool lower_this_thread_priority(int nice) {
#if defined(__linux__)
  // On Linux setpriority(PRIO_PROCESS, tid) sets one thread's nice value (not POSIX, which would mean the process).
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  return setpriority(PRIO_PROCESS, tid, std::clamp(nice, 0, 19)) == 0;
#else
  (void)nice;
  return false;
#endif
}

}  // namespace loopd
