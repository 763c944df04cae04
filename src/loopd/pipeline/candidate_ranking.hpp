#pragma once
/// @file Vlaminck 2019 Sec. 4.1: the gated candidates ranked by place-descriptor distance, best first.
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "loopd/pipeline/distance_gate.hpp"
#include "loopd/pipeline/keyframe_database.hpp"

namespace loopd {

/// @brief A gated keyframe with its descriptor distance to the query.
struct RankedCandidate {
  const KeyframeRecord* match = nullptr;  ///< in the KeyframeDatabase; has features
  double gate_distance = 0.0;             ///< [m] corrected-map distance to the query
  double descriptor_distance = 0.0;       ///< M2DP distance to the query
};

/// @brief The gate's candidates that have features, by descriptor distance (ties: the older key first).
std::vector<RankedCandidate> rank_by_descriptor(const std::vector<GateCandidate>& gated, const Eigen::VectorXf& query_descriptor,
                                                const KeyframeDatabase& keyframes);

/// @brief How many of the best `ranked` to verify: those within max_descriptor_distance, at most max_candidates.
std::size_t count_to_verify(const std::vector<RankedCandidate>& ranked, double max_descriptor_distance, int max_candidates);

}  // namespace loopd
