#pragma once
/// @file The calling thread's CPU priority, for work that should only use the time the pipeline leaves.

namespace loopd {

/// @brief Lowers the calling thread's scheduling priority to `nice` (0-19; Linux: per thread, and inherited by the
///        threads it starts). A thread at nice 19 gets ~1.5 % of a core against a busy nice-0 thread, all of an idle
///        one. Returns false where this is not supported or refused (the thread then keeps its priority).
bool lower_this_thread_priority(int nice);

}  // namespace loopd
