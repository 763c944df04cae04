#include "loopd/pipeline/session_frames.hpp"

namespace loopd {

SessionFrames::Placed SessionFrames::place(const KeyframeKey& key, const Eigen::Isometry3d& T_odom_sensor) {
  Placed placed;
  if (current_ != key.session) {
    Frame& frame = frames_[key.session];
    if (frame.keyframes == 0) frame.group = key.session;
    // Zero motion across the join: the session continues where the previous keyframe lay (the first session: as is).
    frame.T_continuous_odom = current_ ? last_continuous_ * T_odom_sensor.inverse() : Eigen::Isometry3d::Identity();
    placed.starts_segment = current_.has_value();
    if (!map_session_) map_session_ = key.session;
    current_ = key.session;
  }
  Frame& frame = frames_[key.session];
  ++frame.keyframes;
  placed.T_continuous_sensor = frame.T_continuous_odom * T_odom_sensor;
  last_continuous_ = placed.T_continuous_sensor;
  newest_[key.session] = {key, T_odom_sensor};
  return placed;
}

SessionId SessionFrames::group(SessionId session) const {
  const auto it = frames_.find(session);
  return it == frames_.end() ? session : it->second.group;
}

bool SessionFrames::tied(SessionId a, SessionId b) const { return a == b || group(a) == group(b); }

bool SessionFrames::anchored(SessionId session) const { return map_session_ && tied(session, *map_session_); }

std::optional<std::string> SessionFrames::cannot_tie(SessionId query, SessionId match) const {
  if (tied(query, match)) return std::nullopt;
  const SessionId query_group = group(query);
  for (const auto& [id, frame] : frames_)
    if (id != query && frame.group == query_group)
      return "session " + std::to_string(query) + " is already tied to session " + std::to_string(id) + ", not to session " + std::to_string(match) +
             "'s group: the loop would move both";
  return std::nullopt;
}

void SessionFrames::tie(SessionId query, SessionId match) {
  if (tied(query, match)) return;
  frames_[query].group = group(match);
}

std::vector<SessionId> SessionFrames::sessions() const {
  std::vector<SessionId> out;
  for (const auto& entry : frames_) out.push_back(entry.first);
  return out;
}

Eigen::Isometry3d SessionFrames::T_continuous_odom(SessionId session) const {
  const auto it = frames_.find(session);
  return it == frames_.end() ? Eigen::Isometry3d::Identity() : it->second.T_continuous_odom;
}

std::vector<SessionAlignment> SessionFrames::alignments(const std::map<SessionId, Eigen::Isometry3d>& T_map_newest_sensor) const {
  std::vector<SessionAlignment> out;
  for (const auto& [id, frame] : frames_) {
    SessionAlignment a;
    a.session = id;
    a.anchored = anchored(id);
    a.num_keyframes = frame.keyframes;
    const auto pose = T_map_newest_sensor.find(id);
    const auto odom = newest_.find(id);
    if (a.anchored && pose != T_map_newest_sensor.end() && odom != newest_.end()) a.T_map_session = pose->second * odom->second.second.inverse();
    out.push_back(a);
  }
  return out;
}

}  // namespace loopd
