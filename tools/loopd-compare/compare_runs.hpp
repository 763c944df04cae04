#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "run_log.hpp"

namespace loopd::tools {

/// @brief Largest differences that still count as the same result.
struct CompareTolerances {
  double translation_m = 1e-6;  ///< [m] loop transforms and keyframe positions
  double rotation_deg = 1e-6;   ///< [deg] loop transforms and keyframe orientations
};

/// @brief A loop: (query keyframe, match keyframe), each named by (session, id).
using LoopPair = std::pair<KeyframeKey, KeyframeKey>;

/// @brief A loop pair that both runs decided, differently (status or stage, or number of decisions).
struct DecisionDifference {
  LoopPair pair;
  std::string decisions_a;  ///< e.g. "accepted/accepted", several joined with ", "
  std::string decisions_b;
};

/// @brief Loop decisions of two runs side by side.
struct DecisionComparison {
  std::int64_t events_a = 0, events_b = 0;      ///< decoded loop events
  std::int64_t accepted_a = 0, accepted_b = 0;  ///< distinct accepted pairs
  std::int64_t accepted_both = 0;
  std::vector<LoopPair> accepted_only_a, accepted_only_b;  ///< accepted in one run and not in the other, sorted
  std::vector<DecisionDifference> decisions_differ;        ///< pairs both decided, differently, sorted by pair
  std::vector<LoopPair> decided_only_a, decided_only_b;    ///< pairs (any status) only one run decided
  double max_loop_translation_diff_m = 0;                  ///< over pairs accepted in both: T_match_query translation
  double max_loop_rotation_diff_deg = 0;                   ///< ... and rotation
};

/// @brief The last corrected trajectories of two runs side by side, keyframes matched by (session, id).
struct TrajectoryComparison {
  std::int64_t keyframes_a = 0, keyframes_b = 0, keyframes_both = 0;
  bool same_keyframe_ids = true;  ///< the same (session, id) keys in the same order
  std::int64_t revisions_a = 0, revisions_b = 0;
  std::int64_t last_revision_a = -1, last_revision_b = -1;
  double max_pose_translation_diff_m = 0;  ///< over keyframes both have
  double max_pose_rotation_diff_deg = 0;
};

/// @brief Everything loopd-compare reports.
struct RunComparison {
  DecisionComparison loops;
  TrajectoryComparison trajectory;
  bool identical = false;  ///< same decisions, keyframes and revision count; differences within the tolerances
};

/// @brief Compares the loop decisions and last corrected trajectories of two loopd runs (timing fields ignored).
RunComparison compare_runs(const RunLog& a, const RunLog& b, const CompareTolerances& tolerances);

/// @brief Rotation angle between two orientations [deg], accurate for tiny angles (atan2 of the quaternion parts).
double rotation_difference_deg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

}  // namespace loopd::tools
