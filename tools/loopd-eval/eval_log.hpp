#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "loopd/eval/evaluation.hpp"

namespace loopd::tools {

/// @brief Channel names read by loopd-eval.
struct EvalChannels {
  std::string scan = "LIDAR_SCAN";
  std::string odometry = "ODOMETRY_POSE";
  std::string ground_truth = "GROUND_TRUTH_POSE";
  std::string loop_event = "LOOP_EVENT";
  std::string trajectory = "CORRECTED_TRAJECTORY";
};

/// @brief Counters of what was read.
struct LogReadStats {
  std::int64_t events = 0, scans = 0, ground_truth = 0, odometry = 0, loop_events = 0, trajectories = 0;
  std::int64_t malformed = 0, skipped = 0;  ///< undecodable events; events of other channels
  std::int64_t repeated_events = 0;         ///< loop events whose event_id came before (the later replaced the earlier)
  std::int64_t trajectory_revision = -1;    ///< revision used as the corrected trajectory
  /// @brief Adds the counters of `o` (not trajectory_revision).
  void add(const LogReadStats& o);
};

/// @brief Called with (bytes read, total bytes) while reading.
using ProgressFn = std::function<void(std::int64_t, std::int64_t)>;

/// @brief Reads ground truth, odometry and scan utimes of a drive log into `input`. Scan points are NOT decoded:
///        only the utime is taken from the encoded point_cloud_t (a real drive log is gigabytes).
bool read_drive_log(const std::string& path, const EvalChannels& ch, EvalInput* input, LogReadStats* stats, const ProgressFn& progress,
                    std::string* error);

/// @brief Reads loopd's loop events and the LAST corrected trajectory revision into `input`.
bool read_results_log(const std::string& path, const EvalChannels& ch, EvalInput* input, LogReadStats* stats, const ProgressFn& progress,
                      std::string* error);

/// @brief Several drive logs (--drive given more than once) as one: their ground truth, odometry and scans
///        concatenated in the order of their first ground-truth utime (a session's drive has its own utimes, so
///        keyframes still find their ground truth by utime).
void merge_drives(std::vector<EvalInput> drives, EvalInput* input);

/// @brief Adds one results log (read into `part`) to `input`: loop events are concatenated; the corrected trajectory
///        is the one of the log whose last revision holds the most keyframes (a resumed map's holds every
///        session's), the later log on a tie.
void merge_results(EvalInput&& part, const LogReadStats& part_stats, EvalInput* input, LogReadStats* stats);

}  // namespace loopd::tools
