#pragma once
/// @file Which session each keyframe belongs to: a drive on a map continues the map's newest session only when its
/// odometry plainly continues it (a restart of loopd mid-drive); any other drive, and the odometry restarting
/// mid-drive, opens a new session with its own odometry frame (the detector places it by loops).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief How sessions are opened (config `sessions.*`).
struct SessionPolicy {
  bool new_session_on_reset = true;  ///< an odometry reset opens a new session (false: stitched on, zero motion, as before sessions)
  double resume_max_gap = 60.0;      ///< [s] a drive continues the map's newest session only if it starts this soon after it
  double max_speed = 60.0;           ///< [m/s] ... and no farther from its last keyframe than this speed allows
  double min_jump = 2.0;             ///< [m] (never less than this)
  /// The first session id this process may open (a fleet vehicle V: V * kSessionsPerVehicle; ids below it are other
  /// vehicles'). New sessions are numbered from it, or after the newest restored one.
  SessionId first_session = 0;
  std::optional<std::string> validate() const;
};

/// @brief What resume knows of a keyframe the map holds, to recognise it when a replay comes to it again.
struct StoredKeyframe {
  KeyframeKey key;
  std::int64_t utime = 0;
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  std::uint64_t scan_fingerprint = 0;  ///< 0: not known (a map from before fingerprints)
};

/// @brief Keys for the keyframes of this run, on the ingest thread.
class SessionKeys {
 public:
  explicit SessionKeys(const SessionPolicy& policy) : policy_(policy), max_session_(policy.first_session - 1) {}

  /// @brief The map's keyframes (resume, in map order; the last is the newest). With skip_stored, a replay rerun on
  /// its map skips the keyframes the map holds: the run's first keyframe must be a stored session's first one, each
  /// next one that session's next, with the same scan time, the same odometry pose (1 mm, 0.01 deg) and the same scan
  /// fingerprint. Another drive with the same times (two vehicles' logs of one hour, a log replayed onto another's
  /// map) matches none and is a new session, never skipped and never stitched into a stored drive's frame.
  void restore(std::vector<StoredKeyframe> keyframes, bool skip_stored);
  /// @brief The odometry restarted at `utime`; OdometryResetFilter stitches later poses on with T_continuous_odom.
  void on_odometry_reset(std::int64_t utime, const Eigen::Isometry3d& T_continuous_odom);

  struct Assigned {
    bool stored = false;  ///< the map already holds this keyframe (replay resume): skip it
    KeyframeKey key;
    Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();  ///< in the session's own odometry frame
    std::string note;  ///< a line worth logging (a new session, or a replay that is not the map's drive)
  };
  /// @brief A selected keyframe at `utime` whose pose the reset filter gave as T_continuous_sensor.
  Assigned assign(std::int64_t utime, const Eigen::Isometry3d& T_continuous_sensor, std::uint64_t scan_fingerprint = 0);

  std::int64_t skipped() const { return skipped_; }
  std::int64_t sessions_opened() const { return sessions_opened_; }
  SessionId session() const { return session_; }

 private:
  void choose(std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, Assigned& out);
  void open_session(const std::string& why, Assigned& out);
  /// @brief The stored keyframe this replayed one is (skip_stored), or none.
  std::optional<std::size_t> match_stored(std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, std::uint64_t fingerprint) const;
  /// @brief The first keyframe that is not the map's: where the rest of the run goes.
  void leave_stored(std::int64_t utime, Assigned& out);

  SessionPolicy policy_;
  std::vector<StoredKeyframe> stored_;
  std::unordered_multimap<std::int64_t, std::size_t> stored_at_utime_;
  std::unordered_map<SessionId, std::int64_t> stored_newest_index_;  ///< per stored session, its newest keyframe's index
  bool skip_stored_ = false;
  std::optional<std::size_t> last_matched_;
  struct Reset {
    std::int64_t utime;
    Eigen::Isometry3d T_continuous_odom;
  };
  std::vector<Reset> resets_;
  std::size_t next_reset_ = 0;
  Eigen::Isometry3d T_continuous_odom_ = Eigen::Isometry3d::Identity();
  bool reset_pending_ = false;
  bool chosen_ = false;
  SessionId session_ = 0;
  SessionId max_session_ = -1;
  std::int64_t next_index_ = 0;
  std::int64_t skipped_ = 0, sessions_opened_ = 0;
};

}  // namespace loopd
