#pragma once
#include <string>
#include <vector>

#include <loopd/localization_t.hpp>
#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "loop_event_convert.hpp"
#include "loopd/runtime/localization_tracker.hpp"
#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/node_runtime.hpp"

namespace loopd {

/// @brief trajectory_t for one correction with every keyframe (full = true); utime is the publication time [us].
trajectory_t to_message(const CorrectionOutput& c, std::int64_t utime);
/// @brief trajectory_t for one correction without keyframes (revision, event, method, T_map_odom; full = false).
trajectory_t to_message_header(const CorrectionOutput& c, std::int64_t utime);
/// @brief localization_t of one keyframe of a run localizing in a map (loopd --localize).
localization_t to_message(const LocalizationState& s);
/// @brief One keyframe's corrected pose: position and unit quaternion (w, x, y, z).
keyframe_pose_t to_keyframe_pose(std::int64_t id, std::int64_t utime, const Eigen::Isometry3d& T_map_sensor);

/// @brief Counters of one input channel (LCM side).
struct ChannelCounters {
  std::string channel;
  std::int64_t received = 0, accepted = 0, malformed = 0, dropped = 0;
};

/// @brief status_t from the engine's and the channels' counters.
status_t make_status(std::int64_t utime, double uptime_s, const EngineStats& s, const std::vector<ChannelCounters>& channels,
                     std::int64_t memory_bytes, const MapStatus& map = {});

/// @brief Resident memory of this process [bytes] (VmRSS), 0 when unknown.
std::int64_t resident_memory_bytes();

}  // namespace loopd
