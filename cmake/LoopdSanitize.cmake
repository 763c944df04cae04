# Sanitizer builds of everything (library, daemon, tools, tests): LOOPD_SANITIZE = "" (off), "address,undefined" or
# "thread". scripts/sanitize configures build-asan/ or build-tsan/ with it and runs ctest with the matching options.
set(LOOPD_SANITIZE "" CACHE STRING "Sanitizers for the whole build: empty, address,undefined or thread")
set_property(CACHE LOOPD_SANITIZE PROPERTY STRINGS "" "address,undefined" "thread")

if(LOOPD_SANITIZE)
  if(NOT LOOPD_SANITIZE MATCHES "^(address,undefined|undefined,address|address|undefined|thread)$")
    message(FATAL_ERROR "LOOPD_SANITIZE='${LOOPD_SANITIZE}': use address,undefined or thread (or leave it empty)")
  endif()
  # -O1 after the build type's -O2: readable stacks, still fast enough for the drive tests.
  set(loopd_sanitize_flags -fsanitize=${LOOPD_SANITIZE} -fno-omit-frame-pointer -O1 -g)
  if(LOOPD_SANITIZE MATCHES "undefined")
    # A UBSan finding stops the program (and fails its test) instead of printing and going on.
    list(APPEND loopd_sanitize_flags -fno-sanitize-recover=undefined)
  endif()
  add_compile_options(${loopd_sanitize_flags})
  add_link_options(-fsanitize=${LOOPD_SANITIZE})
  # target_clones' ifunc resolver runs before the sanitizer runtime is up (TSan: SIGSEGV before main): see
  # src/loopd/core/target_clones.hpp.
  add_compile_definitions(LOOPD_NO_TARGET_CLONES=1)
  message(STATUS "loopd: sanitizers ${LOOPD_SANITIZE} (${loopd_sanitize_flags})")
endif()
