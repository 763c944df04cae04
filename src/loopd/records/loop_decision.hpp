#pragma once
/// @file The one loop decision record: what the detector decides about a candidate pair, as the stores keep it, the bus
/// carries it (loop_event_t, converted in lcm/loop_event_convert) and loopd-eval and loopd-compare read it back.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "loopd/base/information.hpp"
#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief A decision's status; the values are loop_event_t's STATUS_* constants and the stores' status column.
enum class LoopStatus : std::int8_t { kCandidate = 0, kAccepted = 1, kRejected = 2 };

/// @brief The status a stored or received code names; false for any other code (a damaged row or message).
inline bool loop_status_from_code(std::int64_t code, LoopStatus* status) {
  if (code < 0 || code > 2) return false;
  *status = static_cast<LoopStatus>(code);
  return true;
}
inline std::int8_t status_code(LoopStatus status) { return static_cast<std::int8_t>(status); }
/// @brief "candidate", "accepted" or "rejected" (tables, JSON).
std::string to_string(LoopStatus status);

/// @brief One decision about a (query, match) keyframe pair, with its scores, transform and timings.
struct LoopDecision {
  std::int64_t event_id = 0;
  KeyframeKey query, match;                       ///< query: the newer keyframe; match: the older
  std::int64_t query_utime = 0, match_utime = 0;  ///< [us] scan times of the two keyframes
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
  /// Of T_match_query (verification's GICP Hessian); zero for rejected decisions; stored, not published.
  Information6d information = Information6d::Zero();
  double ms_descriptor = 0.0, ms_fourpcs = 0.0, ms_gicp = 0.0, ms_hungarian = 0.0, ms_total = 0.0;  ///< [ms]; not stored
  /// The decision reached the bus (a store's put_loop keeps false, mark_published sets it; always true on the bus).
  bool published = true;

  bool accepted() const { return status == LoopStatus::kAccepted; }
};

}  // namespace loopd
