#pragma once
/// @file Hands freed heap pages back to the operating system after a large transient allocation (a pose-graph solve).

#include <cstddef>
#include <string>
#include <vector>

namespace loopd {

/// @brief Returns the free pages of every malloc arena to the system (glibc's malloc_trim; a no-op elsewhere). A solve
/// of a large pose graph frees tens of MB at once, which glibc would otherwise keep mapped, and resident, between
/// solves; a long-running daemon's RSS then tracks what it holds, not its largest past solve. Costs a few ms: call it
/// after a solve, not per message.
void release_free_heap();

/// @brief Serves every allocation of 128 KiB or more (scan buffers, keyframe features, solver matrices) from its own
/// mapping, returned to the system when freed (glibc's M_MMAP_THRESHOLD, fixed; a no-op elsewhere). Otherwise glibc
/// raises the threshold as such blocks are freed and carves them from its arenas, where long-lived cached features
/// and short-lived scans leave holes: on a 20 km VLP-16 drive (8000 keyframes, 64 MB feature cache) the resident
/// memory after the warm-up fell from ~320 MB to ~230 MB. Call once at start, before threads are made.
void serve_large_allocations_by_mmap();

/// @brief Tells the kernel it may drop this process's resident pages of the read-only file mappings (code and
/// constants) of the shared libraries whose file name contains one of `libraries` (madvise MADV_PAGEOUT, Linux 5.4+;
/// a no-op elsewhere). Meant for PoCL's compiler, LLVM and clang (~70 MB resident after the M2DP kernels are built,
/// used only while building them): the pages are clean copies of the files, so nothing is lost, and a later use
/// faults them back in from the page cache. Writable mappings (relocated data) are left alone.
/// @return the bytes that were resident in the mappings advised (what the kernel may reclaim)
std::size_t page_out_library_code(const std::vector<std::string>& libraries);

}  // namespace loopd
