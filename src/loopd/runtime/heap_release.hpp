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

/// @brief Keeps allocations up to 64 MiB (scan buffers, keyframe features, solver matrices) in malloc's heap, where a
/// freed scan's pages serve the next scan, and trims the heap's top only past 64 MiB (glibc's M_MMAP_THRESHOLD and
/// M_TRIM_THRESHOLD, fixed; a no-op elsewhere). Serving them from a mapping of their own each (the policy before,
/// M_MMAP_THRESHOLD 128 KiB, for a lower resident size on long drives) cost a fresh zeroed mapping, a page fault per
/// 4 KiB page and a TLB shootdown at munmap for every scan-sized buffer: 12 of 17 s of the demo replay on this
/// project's 2-core VM (issue 32). Holes that long-lived cached features leave between freed scans go back to the
/// system with release_free_heap() after each graph solve. Call once at start, before threads are made.
void keep_large_allocations_in_heap();

/// @brief Tells the kernel it may drop this process's resident pages of the read-only file mappings (code and
/// constants) of the shared libraries whose file name contains one of `libraries` (madvise MADV_PAGEOUT, Linux 5.4+;
/// a no-op elsewhere). Meant for PoCL's compiler, LLVM and clang (~70 MB resident after the M2DP kernels are built,
/// used only while building them): the pages are clean copies of the files, so nothing is lost, and a later use
/// faults them back in from the page cache. Writable mappings (relocated data) are left alone.
/// @return the bytes that were resident in the mappings advised (what the kernel may reclaim)
std::size_t page_out_library_code(const std::vector<std::string>& libraries);

}  // namespace loopd
