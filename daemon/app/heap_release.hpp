#pragma once
/// @file Hands freed heap pages back to the operating system after a large transient allocation (a pose-graph solve).

namespace loopd {

/// @brief Returns the free pages of every malloc arena to the system (glibc's malloc_trim; a no-op elsewhere). A solve
/// of a large pose graph frees tens of MB at once, which glibc would otherwise keep mapped, and resident, between
/// solves; a long-running daemon's RSS then tracks what it holds, not its largest past solve. Costs a few ms: call it
/// after a solve, not per message.
void release_free_heap();

}  // namespace loopd
