#pragma once
/// @file The exit status every loopd program returns (docs/tools.md, "Exit status"): 0 done; 1 it ran and found a
/// problem (a check failed, two runs differ, a write failed on the way); 2 bad input or usage (an unknown or missing
/// option, a file that cannot be read or is not what it should be, a configuration that cannot work, an output path
/// that cannot be opened). test_exit_codes runs every program against this table.
#include <CLI/CLI.hpp>
#include <optional>

namespace loopd::tools {

inline constexpr int kExitOk = 0;
inline constexpr int kExitProblem = 1;
inline constexpr int kExitUsage = 2;

/// @brief Parses the command line: nullopt when the program goes on; otherwise the status to return (kExitOk after
///        --help, kExitUsage after a parse error, which CLI11 prints; its own codes, 105-109, never leave a program).
inline std::optional<int> parse_command_line(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUsage;
  }
  return std::nullopt;
}

}  // namespace loopd::tools
