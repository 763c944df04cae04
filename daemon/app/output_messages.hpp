#pragma once
#include <string>
#include <vector>

#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "loopd_engine.hpp"

namespace loopd {

/// @brief loop_event_t for one decision; utime is the decision time [us].
loop_event_t to_message(const LoopDecision& d, std::int64_t utime);
/// @brief trajectory_t for one correction with every keyframe (full = true); utime is the publication time [us].
trajectory_t to_message(const CorrectionOutput& c, std::int64_t utime);
/// @brief trajectory_t for one correction without keyframes (revision, event, method, T_map_odom; full = false).
trajectory_t to_message_header(const CorrectionOutput& c, std::int64_t utime);
/// @brief One keyframe's corrected pose: position and unit quaternion (w, x, y, z).
keyframe_pose_t to_keyframe_pose(std::int64_t id, std::int64_t utime, const Eigen::Isometry3d& T_map_sensor);

/// @brief Counters of one input channel (LCM side).
struct ChannelCounters {
  std::string channel;
  std::int64_t received = 0, accepted = 0, malformed = 0, dropped = 0;
};

/// @brief status_t from the engine's and the channels' counters.
/// @brief The map store's part of status_t.
struct MapStatus {
  std::string path;                  ///< "" without a map
  std::int64_t bytes = 0;            ///< on disk
  std::int64_t cached_bytes = 0;     ///< keyframe features in memory
  std::int64_t write_failures = 0;   ///< writes given up (MapWriterStats::failures)
  std::int64_t write_retries = 0;    ///< busy retries and tries again from the buffer
  std::int64_t writes_buffered = 0;  ///< writes waiting for the map now
  std::int64_t events_not_republished = 0;
  std::string last_error;
};

status_t make_status(std::int64_t utime, double uptime_s, const EngineStats& s, const std::vector<ChannelCounters>& channels,
                     std::int64_t memory_bytes, const MapStatus& map = {});

/// @brief Resident memory of this process [bytes] (VmRSS), 0 when unknown.
std::int64_t resident_memory_bytes();

}  // namespace loopd
