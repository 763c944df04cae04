#pragma once
/// @file What the map store holds besides keyframe and loop records: sessions, corrections, totals; plain records with
/// frame-named fields, no SQL and no storage types.
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "loopd/base/information.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/keyframe_record.hpp"
#include "loopd/records/loop_decision.hpp"

namespace loopd {

/// @brief One drive (or one segment of it after an odometry reset) with its own odometry frame.
struct SessionRecord {
  SessionId id = 0;
  std::int64_t first_utime = 0;  ///< [us] first keyframe's scan time (0 until known)
  std::string sensor;            ///< lidar model preset the session was processed with
  std::string source;            ///< where the data came from: "live udpm://...", "replay drive.lcmlog"
  /// Alignment of the session's odometry frame in the map frame (identity for the first session).
  Eigen::Isometry3d T_map_session = Eigen::Isometry3d::Identity();
  bool anchored = true;  ///< false until a loop ties the session to the map
};

/// @brief A keyframe as stored: the record (pose, travel, features) and its corrected pose when the row was written.
struct MapKeyframe {
  KeyframeRecord record;  ///< record.features null: shed or unusable scan (pose only)
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
  /// The keyframe's map cloud as encode_map_cloud() made it (store/map_cloud_codec.hpp), written with the keyframe;
  /// null: none (never read back by for_each_keyframe: get_map_cloud reads it).
  std::shared_ptr<const std::vector<std::uint8_t>> map_cloud;
  /// Retired by the place density policy (MapStore::retire_keyframes): a pose row only, its features and map cloud freed.
  bool retired = false;
};

/// @brief How much of a keyframe for_each_keyframe() reads back.
enum class KeyframeLoad {
  kPose,        ///< key, utime, poses, residual, travel; features null
  kDescriptor,  ///< + features with the descriptor and counts, prepared scan left empty (read it with get_prepared)
  kFull,        ///< + the prepared scan
};

/// @brief The correction state after a revision: enough to publish the corrected map again and resume correcting.
struct CorrectionRecord {
  std::int64_t revision = 0;
  std::int64_t loop_event_id = 0;  ///< the accepted loop that made this revision
  std::string method;
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
  std::vector<KeyframeKey> keys;                ///< every keyframe at that revision, in the order added
  std::vector<Eigen::Isometry3d> T_map_sensor;  ///< corrected poses, by keys
  std::vector<std::uint8_t> corrector_state;    ///< the corrector's own resumable state (opaque to the store)
  /// The newest loop ledger entry (records/loop_ledger.hpp) this correction accounts for: the loops revoked by the
  /// entries up to it are not in it (0: made before any entry). A map whose ledger has newer entries is corrected again.
  std::int64_t ledger_seq = 0;
};

/// @brief Totals for `loopd-map info` and status_t.
struct MapStats {
  std::int64_t sessions = 0, keyframes = 0, loops_accepted = 0, loops_rejected = 0;
  std::int64_t loops_revoked = 0;                                          ///< of loops_accepted: revoked by the loop ledger (now)
  std::int64_t keyframes_retired = 0;                                      ///< of keyframes: retired (pose rows only, MapStore::retire_keyframes)
  std::int64_t map_clouds = 0, map_cloud_points = 0, map_cloud_bytes = 0;  ///< keyframes with a map cloud; their points and blob bytes
  std::int64_t bytes = 0;                                                  ///< on disk (database + journal)
};

/// @brief The fleet's joint correction: every session's keyframes and every vehicle's accepted loops solved as one pose
/// graph by the vehicle holding the solver lock (store/shared_map.hpp), so every vehicle publishes the same map.
struct FleetCorrectionRecord {
  std::int64_t revision = 0;                    ///< increases by one with every joint solve (set by put_fleet_correction)
  int solver_vehicle = -1;                      ///< the vehicle that solved it
  std::int64_t loops = 0;                       ///< accepted loops in the graph
  std::int64_t solved_utime = 0;                ///< [us] wall clock when it was solved
  std::vector<KeyframeKey> keys;                ///< every keyframe of every session, by key
  std::vector<Eigen::Isometry3d> T_map_sensor;  ///< corrected poses, by keys
  std::vector<std::int64_t> utimes;             ///< [us] scan times, by keys
  /// Every session, by id.
  struct Session {
    SessionId id = 0;
    bool anchored = false;                                            ///< tied to the map's first session by loops
    Eigen::Isometry3d T_map_session = Eigen::Isometry3d::Identity();  ///< at the session's newest keyframe
    std::int64_t keyframes = 0;
  };
  std::vector<Session> sessions;
};

/// @brief How much a fleet map holds (the solver re-solves when these grow).
struct FleetCounts {
  std::int64_t keyframes = 0;        ///< decided keyframes of every vehicle
  std::int64_t loops_accepted = 0;   ///< accepted loops of every vehicle
  std::int64_t newest_revision = 0;  ///< of the joint correction (0: none yet)
  std::int64_t ledger_seq = 0;       ///< the loop ledger's newest entry (a revoke or restore changes the graph)
};

}  // namespace loopd
