#pragma once
#include <string>

namespace loopd::test {
/// @brief Runs a shell command, returns its stdout and stderr together; `exit_code` gets its exit status (-1 if it
///        did not exit normally).
std::string run_command(const std::string& command, int* exit_code);
/// @brief Runs a shell command that must succeed (a test failure naming the command and its output otherwise);
///        its stdout and stderr together.
std::string run_ok(const std::string& command);
/// @brief The last non-empty line of `text` (where tools print their --json object).
std::string last_line(const std::string& text);
}  // namespace loopd::test
