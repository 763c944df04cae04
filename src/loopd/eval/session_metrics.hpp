#pragma once
// Multi-session figures: how well each later session (a second drive on the same map, or a drive's segment after an
// odometry reset) was tied to the map by loops between sessions. Pure functions on core types, no LCM.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief One keyframe of the corrected trajectory with its ground truth, named by (session, utime).
struct SessionKeyframe {
  std::int32_t session = 0;
  std::int64_t utime = 0;                                     ///< [us] scan utime
  Eigen::Isometry3d T_map = Eigen::Isometry3d::Identity();    ///< corrected pose, map frame
  Eigen::Isometry3d T_world = Eigen::Isometry3d::Identity();  ///< ground truth, world frame
};

/// @brief An accepted loop between two keyframes, with the closure verdict the evaluation gave it.
struct SessionLoop {
  std::int32_t query_session = 0, match_session = 0;
  std::int64_t query_utime = 0;  ///< [us]
  bool correct = false;          ///< T_match_query within the closure tolerance of ground truth
};

/// @brief What the trajectory says about a session (trajectory_t.sessions[]).
struct SessionAnchor {
  std::int32_t session = 0;
  bool anchored = false;  ///< a loop ties the session to the map
};

struct SessionMetricsConfig {
  double mapped_radius = 10.0;  ///< [m] a place is in the mapped area when within this (ground truth) of an earlier session's keyframe
};

/// @brief The figures of one session.
struct SessionStats {
  std::int32_t session = 0;
  int keyframes = 0;
  bool first = false;                             ///< the map's first session (the map frame itself)
  bool anchored = false;                          ///< from SessionAnchor; without one, whether an accepted loop ties it to an earlier session
  std::int64_t first_utime = 0;                   ///< [us] its first keyframe
  std::optional<std::int64_t> anchor_utime;       ///< [us] query utime of its first accepted inter-session loop
  std::optional<double> alignment_error_m;        ///< median translation error of the relative poses to the map [m]
  std::optional<double> alignment_error_deg;      ///< median rotation error of the same [deg]
  int alignment_samples = 0;                      ///< keyframes in those medians
  std::optional<double> distance_to_alignment_m;  ///< [m] ground-truth path in the mapped area before anchor_utime
  double mapped_distance_m = 0;                   ///< [m] ground-truth path in the mapped area over the whole session
};

/// @brief Multi-session figures; "worst" is over the sessions after the first.
struct SessionMetrics {
  int sessions = 0;            ///< distinct sessions (keyframes and anchors)
  int sessions_aligned = 0;    ///< sessions after the first that are anchored
  int sessions_unaligned = 0;  ///< sessions after the first that are not
  int inter_session_loops_accepted = 0, inter_session_loops_correct = 0;
  std::optional<double> alignment_error_m, alignment_error_deg;  ///< worst session median (each on its own)
  std::optional<double> alignment_distance_m;                    ///< worst distance_to_alignment_m
  std::vector<SessionStats> per_session;                         ///< by session id
};

/// @brief The multi-session figures.
///
/// Per session K after the first (the smallest id): alignment error = for each keyframe q of K at or after its first
/// accepted inter-session loop (query in K, match in another session) that lies within `mapped_radius` (ground truth)
/// of a keyframe of an earlier session (smaller id), m = the nearest such keyframe; the error of the corrected
/// T_map_m^-1 T_map_q against the ground truth T_world_m^-1 T_world_q (relative_error). The session's figure is the
/// median over those q, translation and rotation each; null when it is not anchored or has no such q.
/// Distance to alignment = ground-truth path length (`ground_truth` in time order, between the session's first
/// keyframe and its first accepted inter-session loop) over the steps ending within `mapped_radius` of an earlier
/// session's keyframe; null when it has no such loop.
/// @param keyframes the corrected trajectory's keyframes with ground truth (any order)
/// @param loops the ACCEPTED loops (deduplicated), with their verdicts
/// @param anchors the trajectory's session list; empty when the log has none
/// @param ground_truth every ground-truth pose, sorted by utime
SessionMetrics session_metrics(const std::vector<SessionKeyframe>& keyframes, const std::vector<SessionLoop>& loops,
                               const std::vector<SessionAnchor>& anchors, const std::vector<StampedPose>& ground_truth,
                               const SessionMetricsConfig& config = {});

}  // namespace loopd
