#pragma once
/// @file The fleet's joint correction: every vehicle's sessions and every accepted loop (within a session, between
/// sessions, between vehicles) solved as one pose graph, as Vlaminck 2019 Sec. 4.4 / Ren 2019 Sec. 3.4.3 correct one
/// drive. Sessions are chained into one pose sequence, each a segment with a join the graph does not trust
/// (SessionFrames), so the same corrector solves it. No storage and no threads here.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/base/information.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/pipeline/session_frames.hpp"

namespace loopd {

/// @brief A keyframe of some session: its odometry pose in that session's own frame.
struct JointKeyframe {
  KeyframeKey key;
  std::int64_t utime = 0;  ///< [us]
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  double residual = 0.0;  ///< odometry residual since the session's previous keyframe [m]
};

/// @brief An accepted loop between two keyframes (of any sessions).
struct JointLoop {
  KeyframeKey query, match;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  Information6d information = Information6d::Zero();
  bool robust = true;  ///< under the robust kernel (false: a confirmed prior-free loop)
};

struct JointCorrectionConfig {
  LoopCorrectorConfig corrector;  ///< as the detectors' (correction.*)
};

struct JointCorrection {
  bool ok = false;
  std::string error;
  std::vector<KeyframeKey> keys;                ///< every keyframe, by session then index
  std::vector<std::int64_t> utimes;             ///< [us] by keys
  std::vector<Eigen::Isometry3d> T_map_sensor;  ///< corrected poses, by keys
  /// Every session, by id: anchored = tied to the map's session (the lowest id) through loops.
  std::vector<SessionAlignment> sessions;
  std::int64_t loops_used = 0;     ///< loops in the graph
  std::int64_t loops_skipped = 0;  ///< loops naming a keyframe not in `keyframes`, or of zero length
  double ms = 0.0;
};

/// @brief Solves every session of `keyframes` (any order; keys unique) with `loops` as one graph. The map frame is the
/// lowest session's odometry frame; sessions not tied to it by loops stay where their join left them (not anchored).
JointCorrection solve_joint_correction(std::vector<JointKeyframe> keyframes, const std::vector<JointLoop>& loops,
                                       const JointCorrectionConfig& config);

}  // namespace loopd
