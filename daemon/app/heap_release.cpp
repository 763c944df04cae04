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

}  // namespace loopd
