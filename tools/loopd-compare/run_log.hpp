#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace loopd::tools {

/// @brief Channel names read by loopd-compare.
struct CompareChannels {
  std::string loop_event = "LOOP_EVENT";
  std::string trajectory = "CORRECTED_TRAJECTORY";
};

/// @brief One loop decision of a run (loop_event_t without its timing fields and publication utime).
struct LoopDecision {
  std::int64_t event_id = 0;
  std::int64_t query_id = 0;
  std::int64_t match_id = 0;
  std::int8_t status = 0;  ///< loop_event_t::STATUS_*
  std::string stage;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
};

/// @brief One keyframe of a corrected trajectory.
struct KeyframeRecord {
  std::int64_t id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

/// @brief What loopd-compare takes from one loopd output log.
struct RunLog {
  std::vector<LoopDecision> decisions;     ///< every loop event, in log order
  std::vector<KeyframeRecord> trajectory;  ///< the LAST corrected trajectory revision (partial messages applied on
                                           ///< top of the last full one), oldest keyframe first
  std::int64_t revisions = 0;              ///< corrected trajectory revisions in the log (a repeated revision counts once)
  std::int64_t last_revision = -1;         ///< revision number of `trajectory`, -1 when there is none
  std::int64_t events = 0;                 ///< LCM events read (all channels)
  std::int64_t malformed = 0;              ///< loop / trajectory events that did not decode
  std::int64_t repeated_events = 0;        ///< loop events whose event_id came before (the later replaced the earlier)
  std::string first_malformed;             ///< channel, event number and reason of the first of them
  std::string problems;                    ///< LogReader's damage report, and an incomplete trajectory ("" when none)
};

/// @brief Reads loop decisions and the last corrected trajectory of a loopd output log with loopd's log reader and
///        bounded decoder. False (with `error` naming the file) when the file cannot be read or holds no event of
///        either channel; damage inside the log is skipped and reported in `problems` / `malformed`.
bool read_run_log(const std::string& path, const CompareChannels& channels, RunLog* run, std::string* error);

}  // namespace loopd::tools
