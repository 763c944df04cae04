#pragma once
#include <string>

namespace loopd::test {
/// @brief The real-recordings folder: $LOOPD_DATA_DIR, else ../shared/data beside the source tree.
///        Empty when it does not exist (tests then skip with a WARN line).
std::string data_dir();
/// @brief data_dir() + "/" + relative when that file exists, else empty.
std::string data_file(const std::string& relative);
}  // namespace loopd::test

/// Skips the current Catch2 test case cleanly (Catch2 v2 has no SKIP) when a data file is absent.
#define LOOPD_REQUIRE_DATA(var, relative)                                                  \
  const std::string var = loopd::test::data_file(relative);                                \
  if (var.empty()) {                                                                       \
    WARN("skipped: real data file '" << (relative) << "' not found (set LOOPD_DATA_DIR)"); \
    return;                                                                                \
  }
