#pragma once
/// @file What the detector decides about one candidate pair, and how a verification becomes a decision and a loop edge.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "loopd/correction/loop_correction.hpp"
#include "loopd/keyframe/keyframe_key.hpp"
#include "loopd/verify/verify.hpp"

namespace loopd {

enum class LoopStatus { kCandidate = 0, kAccepted = 1, kRejected = 2 };

/// @brief One decision, mirrored 1:1 by loop_event_t.
struct LoopDecision {
  std::int64_t event_id = 0;
  KeyframeKey query, match;
  std::int64_t query_utime = 0, match_utime = 0;  ///< [us]
  LoopStatus status = LoopStatus::kCandidate;
  std::string stage;  ///< gate, descriptor, fourpcs, gicp, degeneracy, hungarian, prior, confirmation, session, accepted
  std::string reason;
  double gate_distance = 0.0, gate_radius = 0.0, descriptor_distance = -1.0;
  double lcp_fraction = -1.0, icp_residual = -1.0, icp_fitness = -1.0, hungarian_consistency = -1.0, degeneracy = -1.0;
  std::string retrieval = "gate";  ///< gate (the distance gate's candidates) or global (place retrieval, no pose prior)
  double place_distance = -1.0;    ///< Scan Context distance of a global candidate (-1: not used)
  /// A prior-free loop that the next keyframes confirmed: its loop edge gets no robust kernel (not published). After
  /// large drift a lone true loop would lose to the odometry under the kernel; the confirmation is its outlier test.
  bool confirmed = false;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  Information6d information = Information6d::Zero();  ///< of T_match_query (verification's GICP Hessian); not published
  double ms_descriptor = 0.0, ms_fourpcs = 0.0, ms_gicp = 0.0, ms_hungarian = 0.0, ms_total = 0.0;
};

/// @brief Copies a verification's verdict, scores, transform and timings into `decision`; ms_total also counts the
/// query's descriptor time (`ms_descriptor`).
void apply_verification(const VerifyResult& verification, double ms_descriptor, LoopDecision& decision);

/// @brief The loop edge an accepted verification gives the correction, between the query and match keyframes at
/// positions `query` and `match` of the corrected pose sequence.
LoopConstraint to_loop_constraint(const VerifyResult& verification, PoseIndex query, PoseIndex match);

}  // namespace loopd
