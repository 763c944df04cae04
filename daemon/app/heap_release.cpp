#include "heap_release.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace loopd {

void release_free_heap() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

void serve_large_allocations_by_mmap() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 128 * 1024);
#endif
}

}  // namespace loopd
