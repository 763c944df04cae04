#pragma once
/// @file Sessions in one pose sequence: each session's odometry frame is stitched onto the end of the previous one
/// (zero motion across the join) so the corrector sees one continuous sequence with a join it must not trust, and
/// loops between sessions tie them into groups; the first session's group is the map.
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief Where a session lies in the corrected map (mirrored by session_alignment_t).
struct SessionAlignment {
  SessionId session = 0;
  bool anchored = false;                                            ///< tied to the map's first session by loops (that session itself: true)
  Eigen::Isometry3d T_map_session = Eigen::Isometry3d::Identity();  ///< at the session's newest keyframe
  std::int64_t num_keyframes = 0;
};

class SessionFrames {
 public:
  /// @brief A keyframe placed in the continuous sequence.
  struct Placed {
    bool starts_segment = false;  ///< first keyframe of its session after another session's (a join before it)
    Eigen::Isometry3d T_continuous_sensor = Eigen::Isometry3d::Identity();
  };

  /// @brief The keyframe `key` at odometry pose T_odom_sensor (its session's own frame), in keyframe order. A session
  /// seen for the first time (or again after another one) is stitched on: its frame is placed so this keyframe lies
  /// where the previous keyframe lay. The first session ever seen is the map (its frame is the continuous frame).
  Placed place(const KeyframeKey& key, const Eigen::Isometry3d& T_odom_sensor);

  /// @brief Sessions a loop has tied together (directly or through others), so their keyframes share one frame.
  bool tied(SessionId a, SessionId b) const;
  /// @brief The group of `session`: the first session of those tied to it.
  SessionId group(SessionId session) const;
  /// @brief Tied to the map's first session.
  bool anchored(SessionId session) const;
  /// @brief Why a loop from `query` (the newest session) to `match` cannot tie them: the query's session is already
  /// tied to sessions other than the match's group (moving it would move them too). Nothing when they may be tied
  /// (or already are).
  std::optional<std::string> cannot_tie(SessionId query, SessionId match) const;
  /// @brief Ties `query`'s session into `match`'s group (after cannot_tie said nothing).
  void tie(SessionId query, SessionId match);

  /// @brief Continuous frame <- the session's odometry frame (identity for an unknown session).
  Eigen::Isometry3d T_continuous_odom(SessionId session) const;
  /// @brief Every session seen, by id; T_map_session from the corrected pose of each one's newest keyframe.
  std::vector<SessionAlignment> alignments(const std::map<SessionId, Eigen::Isometry3d>& T_map_newest_sensor) const;
  /// @brief The newest keyframe of each session: its key and odometry pose.
  const std::map<SessionId, std::pair<KeyframeKey, Eigen::Isometry3d>>& newest() const { return newest_; }
  std::optional<SessionId> current() const { return current_; }
  /// @brief Every session seen, by id.
  std::vector<SessionId> sessions() const;
  std::size_t size() const { return frames_.size(); }

 private:
  struct Frame {
    SessionId group = 0;  ///< the group's first session
    Eigen::Isometry3d T_continuous_odom = Eigen::Isometry3d::Identity();
    std::int64_t keyframes = 0;
  };

  std::map<SessionId, Frame> frames_;
  std::map<SessionId, std::pair<KeyframeKey, Eigen::Isometry3d>> newest_;
  std::optional<SessionId> current_;
  std::optional<SessionId> map_session_;  ///< the first session seen
  Eigen::Isometry3d last_continuous_ = Eigen::Isometry3d::Identity();
};

}  // namespace loopd
