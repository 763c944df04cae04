#include "output_messages.hpp"

#include <Eigen/Geometry>
#include <cstdlib>
#include <fstream>

#include "loopd/base/pose.hpp"

namespace loopd {

trajectory_t to_message_header(const CorrectionOutput& c, std::int64_t utime) {
  trajectory_t m{};
  m.utime = utime;
  m.revision = c.revision;
  m.loop_event_id = c.loop_event_id;
  m.method = c.method;
  to_row_major(c.T_map_odom, m.T_map_odom);
  m.num_keyframes = 0;
  m.full = false;
  m.total_keyframes = static_cast<std::int64_t>(c.T_map_sensor.size());
  for (const SessionAlignment& a : c.sessions) {
    session_alignment_t sa{};
    sa.session = a.session;
    sa.anchored = a.anchored;
    to_row_major(a.T_map_session, sa.T_map_session);
    sa.num_keyframes = a.num_keyframes;
    m.sessions.push_back(sa);
  }
  m.num_sessions = static_cast<std::int32_t>(m.sessions.size());
  return m;
}

keyframe_pose_t to_keyframe_pose(std::int64_t id, std::int64_t utime, const Eigen::Isometry3d& T_map_sensor) {
  keyframe_pose_t k{};
  k.id = id;
  k.utime = utime;
  const Eigen::Vector3d t = T_map_sensor.translation();
  const Eigen::Quaterniond q(T_map_sensor.linear());
  for (int j = 0; j < 3; ++j) k.position[j] = t[j];
  k.orientation[0] = q.w();
  k.orientation[1] = q.x();
  k.orientation[2] = q.y();
  k.orientation[3] = q.z();
  return k;
}

localization_t to_message(const LocalizationState& s) {
  localization_t m{};
  m.utime = s.utime;
  m.session = static_cast<int32_t>(s.keyframe.session);
  m.keyframe_id = s.keyframe.index;
  m.localized = s.localized;
  m.localized_since_utime = s.localized_since_utime;
  m.loops_to_map = static_cast<int32_t>(std::min<std::int64_t>(s.loops_to_map, INT32_MAX));
  m.last_loop_utime = s.last_loop_utime;
  for (int i = 0; i < 16; ++i) m.T_map_odom[i] = s.T_map_odom.matrix()(i / 4, i % 4);
  const keyframe_pose_t pose = to_keyframe_pose(s.keyframe.index, s.utime, s.T_map_sensor);
  for (int j = 0; j < 3; ++j) m.position[j] = pose.position[j];
  for (int j = 0; j < 4; ++j) m.orientation[j] = pose.orientation[j];
  return m;
}

trajectory_t to_message(const CorrectionOutput& c, std::int64_t utime) {
  trajectory_t m = to_message_header(c, utime);
  m.num_keyframes = static_cast<int32_t>(c.T_map_sensor.size());
  m.keyframes.resize(c.T_map_sensor.size());
  m.keyframe_sessions.resize(c.T_map_sensor.size());
  for (std::size_t i = 0; i < c.T_map_sensor.size(); ++i) {
    m.keyframes[i] = to_keyframe_pose(i < c.keys.size() ? c.keys[i].index : static_cast<std::int64_t>(i), i < c.utimes.size() ? c.utimes[i] : 0,
                                      c.T_map_sensor[i]);
    m.keyframe_sessions[i] = i < c.keys.size() ? c.keys[i].session : 0;
  }
  m.full = true;
  return m;
}

status_t make_status(std::int64_t utime, double uptime_s, const EngineStats& s, const std::vector<ChannelCounters>& channels,
                     std::int64_t memory_bytes, const MapStatus& map) {
  status_t m{};
  m.utime = utime;
  m.uptime_s = uptime_s;
  m.num_channels = static_cast<int32_t>(channels.size());
  for (const auto& c : channels) {
    channel_stats_t cs;
    cs.channel = c.channel;
    cs.received = c.received;
    cs.accepted = c.accepted;
    cs.malformed = c.malformed;
    cs.dropped = c.dropped;
    m.channels.push_back(cs);
  }
  m.pending_scans = s.pending_scans;
  m.queue_depth = s.queue_depth;
  m.shed = s.shed;
  m.invalid_scans = s.invalid_scans;
  m.keyframes = s.keyframes;
  m.bytes_per_keyframe = s.bytes_per_keyframe;
  m.loops_accepted = s.loops_accepted;
  m.loops_rejected = s.loops_rejected;
  m.memory_bytes = memory_bytes;
  m.device = s.device;
  m.scans_lost_estimate = s.scans_lost_estimate;
  m.clock_jumps = s.clock_jumps;
  m.odometry_resets = s.odometry_resets;
  m.sensor_changes = s.sensor_changes;
  m.map_path = map.path;
  m.map_bytes = map.bytes;
  m.map_cached_bytes = map.cached_bytes;
  m.map_write_failures = map.write_failures;
  m.map_error = map.last_error;
  m.keyframes_deskewed = s.keyframes_deskewed;
  m.deskew_skipped = s.deskew_skipped;
  m.map_write_retries = map.write_retries;
  m.map_writes_buffered = map.writes_buffered;
  m.session = s.session;
  m.sessions_opened = s.sessions_opened;
  m.keyframes_skipped = s.keyframes_skipped;
  m.events_not_republished = map.events_not_republished;
  return m;
}

std::int64_t resident_memory_bytes() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atoll(line.c_str() + 6) * 1024;
  return 0;
}

}  // namespace loopd
