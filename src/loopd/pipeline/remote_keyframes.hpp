#pragma once
/// @file Other vehicles' keyframes (a fleet sharing one map): candidates for prior-free loops of this vehicle's
/// keyframes, never part of its pose sequence. Their poses are in their own session's odometry frame; where a
/// session lies in this vehicle's map is learnt from the loops to it (and solved jointly elsewhere, by the fleet).
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>

#include "loopd/pipeline/keyframe_database.hpp"

namespace loopd {

class RemoteKeyframes {
 public:
  /// @brief Where a remote session's odometry frame lies relative to this map, as an accepted loop measured it:
  /// T_session_map (a pose in this map -> the same pose in the session's odometry frame).
  struct Placement {
    Eigen::Isometry3d T_session_map = Eigen::Isometry3d::Identity();
    std::int64_t event_id = 0;  ///< the loop that measured it
  };

  /// @brief Adds a keyframe of another vehicle's session (its key must be new); returns the stored copy.
  const KeyframeRecord& add(KeyframeRecord record) { return keyframes_.add(std::move(record)); }
  const KeyframeRecord* find(const KeyframeKey& key) const { return keyframes_.find(key); }
  bool holds_session(SessionId session) const { return sessions_.count(session) > 0; }
  void note_session(SessionId session) { sessions_.emplace(session, std::nullopt); }
  /// @brief The newest accepted loop's placement of `session` (nothing before one).
  const std::optional<Placement>& placement(SessionId session) const;
  void set_placement(SessionId session, const Placement& placement) { sessions_[session] = placement; }
  std::size_t size() const { return keyframes_.size(); }
  std::size_t sessions() const { return sessions_.size(); }

 private:
  KeyframeDatabase keyframes_;
  std::map<SessionId, std::optional<Placement>> sessions_;
};

}  // namespace loopd
