#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/records/loop_decision.hpp"

namespace loopd::tools {

/// @brief Channel names read by loopd-compare.
struct CompareChannels {
  std::string loop_event = "LOOP_EVENT";
  std::string trajectory = "CORRECTED_TRAJECTORY";
};

/// @brief One keyframe of a corrected trajectory.
struct TrajectoryPose {
  std::int32_t session = 0;  ///< a keyframe is named by (session, id)
  std::int64_t id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

/// @brief What loopd-compare takes from one loopd output log.
struct RunLog {
  std::vector<LoopDecision> decisions;     ///< every loop event, in log order (timing fields ignored)
  std::vector<TrajectoryPose> trajectory;  ///< the LAST corrected trajectory revision (partial messages applied on
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
