#pragma once
/// @file loopd's log level (config log_level): which of its stderr lines are written.
namespace loopd {

/// @brief error: only failures (bad config, unusable map, LCM errors, refused map writes); warn: also anomalies in the
/// input, stalls and warnings; info (default): also start-up, per-loop and summary lines.
enum class LogLevel { kError = 0, kWarn = 1, kInfo = 2 };

/// @brief Sets the process's level (main, before any thread starts).
void set_log_level(LogLevel level);
/// @brief Whether a line of `level` is written.
bool log_enabled(LogLevel level);

}  // namespace loopd
