#pragma once
#include <string>
#include <sys/types.h>
#include <vector>

namespace loopd::test {
/// @brief Runs a shell command with its output discarded; its exit status (-1 if it did not exit normally).
int run_quiet(const std::string& command);
/// @brief Starts a program (argv[0] looked up in PATH) as a child process; its pid.
pid_t spawn(const std::vector<std::string>& args);
/// @brief SIGTERM to a child, then waits for it; its exit status (-1 if it did not exit normally).
int stop_process(pid_t pid);
}  // namespace loopd::test
