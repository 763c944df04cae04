#pragma once
/// @brief LOOPD_TARGET_CLONES(...): GCC's target_clones (one variant per ISA, picked at load time by an ifunc resolver)
/// in normal builds; nothing in sanitizer builds. The resolver runs during relocation, before a sanitizer runtime is up,
/// and is itself instrumented: a ThreadSanitizer build died with SIGSEGV before main. Sanitizer builds (CMake option
/// LOOPD_SANITIZE, which defines LOOPD_NO_TARGET_CLONES) therefore compile the plain baseline variant only.

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define LOOPD_SANITIZER_BUILD 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__) || defined(LOOPD_NO_TARGET_CLONES)
#define LOOPD_SANITIZER_BUILD 1
#endif

#if defined(LOOPD_SANITIZER_BUILD)
#define LOOPD_TARGET_CLONES(...)
#else
#define LOOPD_TARGET_CLONES(...) __attribute__((target_clones(__VA_ARGS__)))
#endif
