#include "loopd/runtime/heap_release.hpp"

#include <cstdint>
#include <fstream>
#include <sstream>

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace loopd {

void release_free_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void keep_large_allocations_in_heap() {
#if defined(__GLIBC__)
  constexpr int kLargest = 64 * 1024 * 1024;
  mallopt(M_MMAP_THRESHOLD, kLargest);
  mallopt(M_TRIM_THRESHOLD, kLargest);
#endif
}

namespace {

/// One mapping of /proc/self/smaps: its range, whether it is writable, its file and its resident bytes.
struct Mapping {
  std::uintptr_t begin = 0, end = 0;
  bool writable = false;
  std::string path;
  std::size_t rss = 0;
};

std::vector<Mapping> read_mappings() {
  std::vector<Mapping> mappings;
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  while (std::getline(smaps, line)) {
    if (line.rfind("Rss:", 0) == 0 && !mappings.empty()) {
      mappings.back().rss = static_cast<std::size_t>(std::stoull(line.substr(4))) * 1024;
      continue;
    }
    std::istringstream in(line);
    std::string range, perms, offset, device, inode, path;
    if (!(in >> range >> perms >> offset >> device >> inode)) continue;
    const std::size_t dash = range.find('-');
    if (dash == std::string::npos || perms.size() < 4 || range.find(':') != std::string::npos) continue;
    in >> path;
    Mapping m;
    m.begin = static_cast<std::uintptr_t>(std::stoull(range.substr(0, dash), nullptr, 16));
    m.end = static_cast<std::uintptr_t>(std::stoull(range.substr(dash + 1), nullptr, 16));
    m.writable = perms[1] == 'w';
    m.path = path;
    mappings.push_back(m);
  }
  return mappings;
}

}  // namespace

std::size_t page_out_library_code(const std::vector<std::string>& libraries) {
  std::size_t advised = 0;
#if defined(__linux__) && defined(MADV_PAGEOUT)
  for (const Mapping& m : read_mappings()) {
    if (m.writable || m.rss == 0 || m.path.empty()) continue;
    const std::string name = m.path.substr(m.path.rfind('/') + 1);
    bool wanted = false;
    for (const std::string& l : libraries) wanted = wanted || name.find(l) != std::string::npos;
    if (wanted && madvise(reinterpret_cast<void*>(m.begin), m.end - m.begin, MADV_PAGEOUT) == 0) advised += m.rss;
  }
#else
  (void)libraries;
#endif
  return advised;
}

}  // namespace loopd
