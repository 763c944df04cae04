#include "compare_runs.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

namespace loopd::tools {
namespace {

/// Every decision about one loop pair, in log order.
struct PairDecisions {
  std::vector<std::string> decisions;  ///< "status/stage"
  const LoopDecision* first_accepted = nullptr;
};

using DecisionsByPair = std::map<LoopPair, PairDecisions>;

DecisionsByPair group_by_pair(const std::vector<LoopDecision>& decisions) {
  DecisionsByPair out;
  for (const auto& d : decisions) {
    PairDecisions& p = out[{d.query, d.match}];
    p.decisions.push_back(to_string(d.status) + "/" + d.stage);
    if (d.accepted() && p.first_accepted == nullptr) p.first_accepted = &d;
  }
  return out;
}

std::string joined(const std::vector<std::string>& parts) {
  std::string s;
  for (const auto& p : parts) s += (s.empty() ? "" : ", ") + p;
  return s;
}

/// Larger of `current` and `d`; NaN wins, so a NaN difference is never within a tolerance.
double max_keeping_nan(double current, double d) { return (std::isnan(d) || d > current) ? d : current; }

/// Pairs decided by only one run, and pairs accepted by only one run.
void one_sided_pairs(const DecisionsByPair& mine, const DecisionsByPair& other, std::vector<LoopPair>* decided_only,
                     std::vector<LoopPair>* accepted_only, std::int64_t* accepted) {
  for (const auto& [pair, d] : mine) {
    const auto it = other.find(pair);
    if (it == other.end()) decided_only->push_back(pair);
    if (d.first_accepted == nullptr) continue;
    ++*accepted;
    if (it == other.end() || it->second.first_accepted == nullptr) accepted_only->push_back(pair);
  }
}

/// Pairs both runs decided: differing decisions, and the transform differences of pairs both accepted.
void common_pairs(const DecisionsByPair& a, const DecisionsByPair& b, DecisionComparison* out) {
  for (const auto& [pair, da] : a) {
    const auto it = b.find(pair);
    if (it == b.end()) continue;
    const PairDecisions& db = it->second;
    if (da.decisions != db.decisions) out->decisions_differ.push_back({pair, joined(da.decisions), joined(db.decisions)});
    if (da.first_accepted == nullptr || db.first_accepted == nullptr) continue;
    ++out->accepted_both;
    const Eigen::Isometry3d& Ta = da.first_accepted->T_match_query;
    const Eigen::Isometry3d& Tb = db.first_accepted->T_match_query;
    out->max_loop_translation_diff_m = max_keeping_nan(out->max_loop_translation_diff_m, (Ta.translation() - Tb.translation()).norm());
    out->max_loop_rotation_diff_deg =
        max_keeping_nan(out->max_loop_rotation_diff_deg, rotation_difference_deg(Eigen::Quaterniond(Ta.linear()), Eigen::Quaterniond(Tb.linear())));
  }
}

DecisionComparison compare_decisions(const RunLog& a, const RunLog& b) {
  DecisionComparison out;
  out.events_a = static_cast<std::int64_t>(a.decisions.size());
  out.events_b = static_cast<std::int64_t>(b.decisions.size());
  const DecisionsByPair by_pair_a = group_by_pair(a.decisions);
  const DecisionsByPair by_pair_b = group_by_pair(b.decisions);
  one_sided_pairs(by_pair_a, by_pair_b, &out.decided_only_a, &out.accepted_only_a, &out.accepted_a);
  one_sided_pairs(by_pair_b, by_pair_a, &out.decided_only_b, &out.accepted_only_b, &out.accepted_b);
  common_pairs(by_pair_a, by_pair_b, &out);
  return out;
}

TrajectoryComparison compare_trajectories(const RunLog& a, const RunLog& b) {
  TrajectoryComparison out;
  out.keyframes_a = static_cast<std::int64_t>(a.trajectory.size());
  out.keyframes_b = static_cast<std::int64_t>(b.trajectory.size());
  out.revisions_a = a.revisions;
  out.revisions_b = b.revisions;
  out.last_revision_a = a.last_revision;
  out.last_revision_b = b.last_revision;
  out.same_keyframe_ids = a.trajectory.size() == b.trajectory.size() &&
                          std::equal(a.trajectory.begin(), a.trajectory.end(), b.trajectory.begin(),
                                     [](const TrajectoryPose& x, const TrajectoryPose& y) { return x.session == y.session && x.id == y.id; });
  std::map<KeyframeKey, const TrajectoryPose*> b_by_key;
  for (const auto& k : b.trajectory) b_by_key.emplace(KeyframeKey{k.session, k.id}, &k);
  for (const auto& ka : a.trajectory) {
    const auto it = b_by_key.find(KeyframeKey{ka.session, ka.id});
    if (it == b_by_key.end()) continue;
    const TrajectoryPose& kb = *it->second;
    ++out.keyframes_both;
    out.max_pose_translation_diff_m = max_keeping_nan(out.max_pose_translation_diff_m, (ka.position - kb.position).norm());
    out.max_pose_rotation_diff_deg = max_keeping_nan(out.max_pose_rotation_diff_deg, rotation_difference_deg(ka.orientation, kb.orientation));
  }
  return out;
}

bool within(double difference, double tolerance) { return difference <= tolerance; }  // false for NaN

}  // namespace

double rotation_difference_deg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Eigen::Quaterniond d = a.normalized().conjugate() * b.normalized();
  // 2 atan2(|v|, |w|): the smaller of the two angles q and -q stand for, exact near zero (acos of the trace is not).
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w())) * 180.0 / M_PI;
}

RunComparison compare_runs(const RunLog& a, const RunLog& b, const CompareTolerances& tolerances) {
  RunComparison out;
  out.loops = compare_decisions(a, b);
  out.trajectory = compare_trajectories(a, b);
  const DecisionComparison& l = out.loops;
  const TrajectoryComparison& t = out.trajectory;
  const bool same_decisions = l.events_a == l.events_b && l.accepted_only_a.empty() && l.accepted_only_b.empty() && l.decisions_differ.empty() &&
                              l.decided_only_a.empty() && l.decided_only_b.empty();
  const bool same_loops =
      within(l.max_loop_translation_diff_m, tolerances.translation_m) && within(l.max_loop_rotation_diff_deg, tolerances.rotation_deg);
  const bool same_trajectory = t.same_keyframe_ids && t.revisions_a == t.revisions_b &&
                               within(t.max_pose_translation_diff_m, tolerances.translation_m) &&
                               within(t.max_pose_rotation_diff_deg, tolerances.rotation_deg);
  out.identical = same_decisions && same_loops && same_trajectory;
  return out;
}

}  // namespace loopd::tools
