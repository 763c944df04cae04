# libFuzzer targets (test/fuzz, scripts/fuzz): LOOPD_FUZZ=ON needs clang. Everything compiled in such a build gets
# ASan + UBSan and libFuzzer's coverage instrumentation, so a bug inside a library a target calls is found too; the
# fuzz targets themselves link -fsanitize=fuzzer. Line tables only (what a sanitizer's stack trace needs): full debug
# information made the instrumented Eigen code a quarter slower to compile. Off by default: the normal build is unchanged.
option(LOOPD_FUZZ "Build the libFuzzer targets of test/fuzz (clang only; instruments the whole build)" OFF)

if(LOOPD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "LOOPD_FUZZ=ON needs clang (CMAKE_CXX_COMPILER=clang++), not ${CMAKE_CXX_COMPILER_ID}")
  endif()
  set(loopd_fuzz_flags -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -gline-tables-only -O1)
  add_compile_options(${loopd_fuzz_flags})
  add_link_options(-fsanitize=address,undefined)
  add_compile_definitions(LOOPD_NO_TARGET_CLONES=1)
  message(STATUS "loopd: fuzz build (${loopd_fuzz_flags})")
endif()
