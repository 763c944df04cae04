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
  # src/loopd/base/target_clones.hpp.
  add_compile_definitions(LOOPD_NO_TARGET_CLONES=1)
  if(LOOPD_SANITIZE MATCHES "undefined")
    # GCC 12's -fsanitize=vptr miscompiles LCM 1.3.1's subscription callback (lcm-cpp-impl.hpp:108, the pointer-to-member
    # handler call through the subscription object): the handler ran with a wrong `this` (UBSan: "member access within
    # address ... which does not point to an object of type 'LCMMHUntypedSubscription'", then "member call on misaligned
    # address 0xbebebe0000000001"; ASan: a write into a global). A 25-line program with LCM's memq:// does the same and
    # is clean and correct with -fno-sanitize=vptr. A suppression cannot help (the wrong call happens either way), so the
    # translation units that subscribe with a member handler are built without the vptr check; all other checks stay.
    function(loopd_sanitize_lcm_subscribers)
      set_property(SOURCE ${CMAKE_SOURCE_DIR}/daemon/app/lcm_node.cpp DIRECTORY ${CMAKE_SOURCE_DIR}/daemon
                   APPEND PROPERTY COMPILE_OPTIONS -fno-sanitize=vptr)
      if(LOOPD_BUILD_TESTS)
        # test_messages.cpp, or the one translation unit of test/app/ that holds it (test/CMakeLists.txt).
        set_property(SOURCE ${CMAKE_SOURCE_DIR}/test/app/test_messages.cpp ${CMAKE_BINARY_DIR}/test/units/test_app.cpp
                     DIRECTORY ${CMAKE_SOURCE_DIR}/test APPEND PROPERTY COMPILE_OPTIONS -fno-sanitize=vptr)
      endif()
    endfunction()
    cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL loopd_sanitize_lcm_subscribers)
  endif()
  message(STATUS "loopd: sanitizers ${LOOPD_SANITIZE} (${loopd_sanitize_flags})")
endif()
