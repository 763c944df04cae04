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

#include "loopd/keyframe/keyframe_key.hpp"

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

/// @brief Keys for the keyframes of this run, on the ingest thread.
class SessionKeys {
 public:
  explicit SessionKeys(const SessionPolicy& policy) : policy_(policy), max_session_(policy.first_session - 1) {}

  /// @brief The map's keyframes (resume, in map order) and the odometry pose of the newest one. With skip_stored, the
  /// keyframes of a replay that the map already holds are recognised by their scan times (and skipped).
  void restore(const std::vector<KeyframeKey>& keys, const std::vector<std::int64_t>& utimes, const Eigen::Isometry3d& T_odom_newest,
               bool skip_stored);
  /// @brief The odometry restarted at `utime`; OdometryResetFilter stitches later poses on with T_continuous_odom.
  void on_odometry_reset(std::int64_t utime, const Eigen::Isometry3d& T_continuous_odom);

  struct Assigned {
    bool stored = false;  ///< the map already holds this keyframe (replay resume): skip it
    KeyframeKey key;
    Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();  ///< in the session's own odometry frame
    std::string note;  ///< a line worth logging (a new session, or a replay that is not the map's drive)
  };
  /// @brief A selected keyframe at `utime` whose pose the reset filter gave as T_continuous_sensor.
  Assigned assign(std::int64_t utime, const Eigen::Isometry3d& T_continuous_sensor);

  std::int64_t skipped() const { return skipped_; }
  std::int64_t sessions_opened() const { return sessions_opened_; }
  SessionId session() const { return session_; }

 private:
  void choose(std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, Assigned& out);
  void open_session(const std::string& why, Assigned& out);

  SessionPolicy policy_;
  std::vector<KeyframeKey> stored_keys_;
  std::unordered_map<std::int64_t, std::size_t> stored_at_utime_;
  std::vector<std::int64_t> stored_utimes_;
  Eigen::Isometry3d T_odom_newest_ = Eigen::Isometry3d::Identity();
  bool skip_stored_ = false, matched_stored_ = false;
  std::size_t next_stored_ = 0;
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
