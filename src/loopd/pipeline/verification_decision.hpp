#pragma once
/// @file How a verification becomes a loop decision (records/loop_decision.hpp) and a loop edge.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "loopd/correction/loop_correction.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/records/loop_decision.hpp"
#include "loopd/verify/verify.hpp"

namespace loopd {

/// @brief Copies a verification's verdict, scores, transform and timings into `decision`; ms_total also counts the
/// query's descriptor time (`ms_descriptor`).
void apply_verification(const VerifyResult& verification, double ms_descriptor, LoopDecision& decision);

/// @brief The loop edge an accepted verification gives the correction, between the query and match keyframes at
/// positions `query` and `match` of the corrected pose sequence.
LoopConstraint to_loop_constraint(const VerifyResult& verification, PoseIndex query, PoseIndex match);

}  // namespace loopd
