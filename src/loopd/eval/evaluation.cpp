#include "loopd/eval/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

#include "loopd/eval/evaluation_internal.hpp"

namespace loopd {
namespace {

using detail::FrameIndex;

bool has_descriptor(const LoopDecision& r) { return std::isfinite(r.descriptor_distance) && r.descriptor_distance >= 0.0 && r.stage != "gate"; }

int status_rank(LoopStatus s) {
  switch (s) {
    case LoopStatus::kAccepted:
      return 2;
    case LoopStatus::kRejected:
      return 1;
    default:
      return 0;
  }
}

TimingStats timing_stats(const std::vector<LoopDecision>& loops, double LoopDecision::*field) {
  std::vector<double> v;
  for (const auto& l : loops)
    if (l.*field > 0.0 && std::isfinite(l.*field)) v.push_back(l.*field);
  TimingStats t;
  const ErrorStats s = error_stats(v);
  t.median = s.median;
  t.p95 = s.p95;
  t.max = s.max;
  t.count = s.count;
  return t;
}

std::vector<Eigen::Vector3d> positions_of(const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<Eigen::Vector3d> p;
  p.reserve(poses.size());
  for (const auto& T : poses) p.push_back(T.translation());
  return p;
}

/// @brief Index of the keyframe with utime `u` in the sorted `keyframe_utimes`, or -1.
int keyframe_index(const std::vector<std::int64_t>& keyframe_utimes, std::int64_t u) {
  auto it = std::lower_bound(keyframe_utimes.begin(), keyframe_utimes.end(), u);
  if (it == keyframe_utimes.end() || *it != u) return -1;
  return static_cast<int>(it - keyframe_utimes.begin());
}

using LoopPair = std::pair<std::int64_t, std::int64_t>;  ///< (query utime, match utime)

/// @brief One verdict per (query, match) pair: the decisive event is the accepted one, else rejected, else candidate.
struct PairVerdicts {
  std::map<LoopPair, std::size_t> decisive;  ///< index into the loop events
  std::map<LoopPair, double> best_distance;  ///< smallest descriptor distance of the pair's events
};

PairVerdicts pair_verdicts(const std::vector<LoopDecision>& loops) {
  PairVerdicts v;
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const auto& l = loops[i];
    const auto key = std::make_pair(l.query_utime, l.match_utime);
    auto it = v.decisive.find(key);
    if (it == v.decisive.end() || status_rank(l.status) >= status_rank(loops[it->second].status)) v.decisive[key] = i;
    if (has_descriptor(l)) {
      auto d = v.best_distance.find(key);
      if (d == v.best_distance.end() || l.descriptor_distance < d->second) v.best_distance[key] = l.descriptor_distance;
    }
  }
  return v;
}

/// @brief The decisive event `l` (index `idx`) against ground truth: keyframes, frame gap, true loop, and the error of
/// its T_match_query.
LoopCheck check_loop(std::size_t idx, const LoopDecision& l, const std::vector<std::int64_t>& keyframe_utimes, const std::vector<StampedPose>& gt,
                     const FrameIndex& frames, const EvalConfig& config) {
  const std::int64_t gi = config.max_interpolation_gap_us, gn = config.max_nearest_gap_us;
  LoopCheck c;
  c.loop = idx;
  c.query_keyframe = keyframe_index(keyframe_utimes, l.query_utime);
  c.match_keyframe = keyframe_index(keyframe_utimes, l.match_utime);
  const auto gq = pose_at(gt, l.query_utime, gi, gn);
  const auto gm = pose_at(gt, l.match_utime, gi, gn);
  c.frame_gap = std::abs(frames.frame_of(l.query_utime) - frames.frame_of(l.match_utime));
  if (gq && gm) {
    c.has_ground_truth = true;
    c.gt_distance = place_distance(gq->translation(), gm->translation(), config.ground_truth);
    c.true_loop =
        is_true_loop(gq->translation(), frames.frame_of(l.query_utime), gm->translation(), frames.frame_of(l.match_utime), config.ground_truth);
    // Vlaminck 2019, 5.4 closes loops with T_match_query; the truth is GT_match^-1 * GT_query.
    const RelativeError e = relative_error(l.T_match_query, gm->inverse() * *gq);
    c.translation_error = e.translation;
    c.rotation_error_deg = e.rotation_deg;
  }
  return c;
}

/// @brief What the loop pairs add up to: the precision-recall inputs and the revisit keyframes they cover.
struct LoopTally {
  std::vector<double> pr_dist;                                    ///< best descriptor distance of each pair that has one
  std::vector<bool> pr_true;                                      ///< ... whether it is a true loop
  std::vector<int> pr_query;                                      ///< ... its query keyframe when that is a revisit, else -1
  std::set<int> covered_detect, covered_accept, covered_correct;  ///< revisit query keyframes with a true / any / correct accepted loop
};

/// @brief An accepted loop: closure correctness (Vlaminck 2019, 5.4), detection TP/FP and the revisits it covers.
void count_accepted(LoopCheck& c, bool q_revisit, const EvalConfig& config, EvalReport& rep, LoopTally& tally) {
  ++rep.closure.accepted;
  c.correct = c.has_ground_truth && c.translation_error <= config.closure_max_translation && c.rotation_error_deg <= config.closure_max_rotation_deg;
  if (c.correct) ++rep.closure.correct;
  if (c.true_loop) {
    ++rep.detection.true_positives;
    if (q_revisit) tally.covered_detect.insert(c.query_keyframe);
  } else {
    ++rep.detection.false_positives;
  }
  if (q_revisit) tally.covered_accept.insert(c.query_keyframe);
  if (q_revisit && c.correct) tally.covered_correct.insert(c.query_keyframe);
}

/// @brief Checks every deduplicated loop pair (rep.checks) and counts the accepted ones.
LoopTally check_loops(const EvalInput& in, const std::vector<StampedPose>& gt, const FrameIndex& frames, const EvalConfig& config, EvalReport& rep) {
  const PairVerdicts verdicts = pair_verdicts(in.loops);
  const LoopGroundTruth& lgt = rep.loop_ground_truth;
  LoopTally tally;
  for (const auto& [key, idx] : verdicts.decisive) {
    const LoopDecision& l = in.loops[idx];
    LoopCheck c = check_loop(idx, l, rep.keyframe_utimes, gt, frames, config);
    const bool q_revisit = c.query_keyframe >= 0 && lgt.revisit[static_cast<std::size_t>(c.query_keyframe)];
    if (l.status == LoopStatus::kAccepted) count_accepted(c, q_revisit, config, rep, tally);
    const auto bd = verdicts.best_distance.find(key);
    if (bd != verdicts.best_distance.end()) {
      tally.pr_dist.push_back(bd->second);
      tally.pr_true.push_back(c.true_loop);
      tally.pr_query.push_back(q_revisit ? c.query_keyframe : -1);
    }
    rep.checks.push_back(c);
  }
  return tally;
}

/// @brief Maximal recall (and the precision there) and the best F1 along the PR curve.
void summarize_pr_curve(DetectionMetrics& d) {
  for (const auto& p : d.pr_curve) {
    // The first point reaching the maximal recall has the highest precision among those points.
    if (p.recall > d.max_recall + 1e-12) {
      d.max_recall = p.recall;
      d.precision_at_max_recall = p.precision;
    }
    const double f1 = (p.precision + p.recall) > 0 ? 2 * p.precision * p.recall / (p.precision + p.recall) : 0.0;
    if (f1 > d.f1_max) {
      d.f1_max = f1;
      d.f1_max_threshold = p.threshold;
    }
  }
  if (!d.pr_curve.empty() && d.max_recall == 0.0) d.precision_at_max_recall = d.pr_curve.back().precision;
}

/// @brief Detection metrics (Vlaminck 2019, 5.3) from the TP/FP counted on accepted loops and the PR curve.
void fill_detection_metrics(const LoopTally& tally, const LoopGroundTruth& lgt, DetectionMetrics& d) {
  d.gt_queries = lgt.num_queries;
  d.gt_pairs = lgt.num_pairs;
  d.false_negatives = lgt.num_queries - static_cast<int>(tally.covered_detect.size());
  const int predicted = d.true_positives + d.false_positives;
  d.precision = predicted > 0 ? static_cast<double>(d.true_positives) / predicted : 0.0;
  d.recall = lgt.num_queries > 0 ? static_cast<double>(tally.covered_detect.size()) / lgt.num_queries : 0.0;
  d.f1 = (d.precision + d.recall) > 0 ? 2 * d.precision * d.recall / (d.precision + d.recall) : 0.0;
  d.pr_curve = precision_recall_curve(tally.pr_dist, tally.pr_true, tally.pr_query, lgt.num_queries);
  summarize_pr_curve(d);
}

/// @brief Closure metrics from the accepted / correct counts and the revisits and stretches they cover.
void fill_closure_metrics(const LoopTally& tally, const LoopGroundTruth& lgt, ClosureMetrics& cm) {
  cm.precision = cm.accepted > 0 ? static_cast<double>(cm.correct) / cm.accepted : 0.0;
  cm.recall = lgt.num_queries > 0 ? static_cast<double>(tally.covered_accept.size()) / lgt.num_queries : 0.0;
  cm.recall_correct = lgt.num_queries > 0 ? static_cast<double>(tally.covered_correct.size()) / lgt.num_queries : 0.0;
  cm.stretches = static_cast<int>(lgt.stretches.size());
  for (const auto& [first, last] : lgt.stretches) {
    auto it = tally.covered_correct.lower_bound(first);
    const bool closed = it != tally.covered_correct.end() && *it <= last;
    if (closed) ++cm.stretches_closed;
    cm.stretch_list.push_back({first, last, closed});
  }
  cm.stretches_closed_share = cm.stretches > 0 ? static_cast<double>(cm.stretches_closed) / cm.stretches : 0.0;
}

/// @brief Vlaminck 2019, Table 4: distance of every pose to its closest ground-truth pose; plus ATE RMSE.
void fill_pose_errors(EvalReport& rep) {
  const auto before_p = positions_of(rep.before_keyframes);
  const auto after_p = positions_of(rep.after_keyframes);
  const auto gt_p = positions_of(rep.gt_keyframes);
  rep.error_before = error_stats(closest_pose_errors(before_p, rep.gt_path));
  rep.error_after = error_stats(closest_pose_errors(after_p, rep.gt_path));
  rep.ate_before = ate_rmse(before_p, gt_p);
  rep.ate_after = ate_rmse(after_p, gt_p);
}

/// @brief How far the accepted loops' T_match_query lie from ground truth (the closure tolerance's two quantities).
void fill_loop_errors(const std::vector<LoopDecision>& loops, EvalReport& rep) {
  std::vector<double> translation, rotation;
  for (const LoopCheck& c : rep.checks)
    if (c.has_ground_truth && loops[c.loop].status == LoopStatus::kAccepted) {
      translation.push_back(c.translation_error);
      rotation.push_back(c.rotation_error_deg);
    }
  rep.loop_translation_error = error_stats(translation);
  rep.loop_rotation_error_deg = error_stats(rotation);
}

/// @brief Multi-session figures over the corrected trajectory's keyframes that have ground truth, and the accepted
/// loop pairs with their closure verdicts.
void fill_session_metrics(const EvalInput& in, const std::vector<StampedPose>& gt, const EvalConfig& config, EvalReport& rep) {
  std::vector<SessionKeyframe> kfs;
  for (const KeyframePose& k : in.corrected) {
    const auto g = pose_at(gt, k.utime, config.max_interpolation_gap_us, config.max_nearest_gap_us);
    if (g) kfs.push_back({k.session, k.utime, k.T_map_sensor, *g});
  }
  std::vector<SessionLoop> loops;
  for (const LoopCheck& c : rep.checks) {
    const LoopDecision& l = in.loops[c.loop];
    if (l.status == LoopStatus::kAccepted) loops.push_back({l.query.session, l.match.session, l.query_utime, c.correct});
  }
  rep.sessions = session_metrics(kfs, loops, in.sessions, gt, config.sessions);
}

/// @brief Per-stage timings over the loop events.
void fill_timings(const std::vector<LoopDecision>& loops, EvalReport& rep) {
  rep.ms_descriptor = timing_stats(loops, &LoopDecision::ms_descriptor);
  rep.ms_fourpcs = timing_stats(loops, &LoopDecision::ms_fourpcs);
  rep.ms_gicp = timing_stats(loops, &LoopDecision::ms_gicp);
  rep.ms_hungarian = timing_stats(loops, &LoopDecision::ms_hungarian);
  rep.ms_total = timing_stats(loops, &LoopDecision::ms_total);
}

}  // namespace

std::optional<std::string> EvalConfig::validate() const {
  if (auto e = ground_truth.validate()) return e;
  if (!(closure_max_translation > 0)) return "eval: closure_max_translation must be > 0 m";
  if (!(closure_max_rotation_deg > 0)) return "eval: closure_max_rotation_deg must be > 0 deg";
  if (max_interpolation_gap_us < 0 || max_nearest_gap_us < 0) return "eval: time gaps must be >= 0 us";
  if (!(sessions.mapped_radius > 0) || !std::isfinite(sessions.mapped_radius)) return "eval: the mapped-area radius must be > 0 m";
  return std::nullopt;
}

std::vector<PrPoint> precision_recall_curve(const std::vector<double>& distances, const std::vector<bool>& is_true,
                                            const std::vector<int>& query_keyframes, int gt_queries) {
  std::vector<PrPoint> curve;
  const std::size_t n = std::min({distances.size(), is_true.size(), query_keyframes.size()});
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return distances[a] < distances[b]; });
  std::set<int> covered;
  int tp = 0, fp = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = order[k];
    if (is_true[i]) {
      ++tp;
      if (query_keyframes[i] >= 0) covered.insert(query_keyframes[i]);
    } else {
      ++fp;
    }
    // Emit one point per distinct threshold, after all ties.
    if (k + 1 < n && distances[order[k + 1]] == distances[i]) continue;
    PrPoint p;
    p.threshold = distances[i];
    p.true_positives = tp;
    p.false_positives = fp;
    p.precision = static_cast<double>(tp) / static_cast<double>(tp + fp);
    p.recall = gt_queries > 0 ? static_cast<double>(covered.size()) / gt_queries : 0.0;
    curve.push_back(p);
  }
  return curve;
}

EvalReport evaluate(const EvalInput& in, const EvalConfig& config) {
  EvalReport rep;
  if (auto e = config.validate()) {
    rep.error = *e;
    return rep;
  }
  detail::SortedTrajectories tr;
  tr.gt = detail::sorted_by_time(in.ground_truth);
  tr.odom = detail::sorted_by_time(in.odometry);
  if (tr.gt.empty()) {
    rep.error = "no ground-truth poses in the drive";
    return rep;
  }
  for (const auto& p : tr.gt) rep.gt_path.push_back(p.T_world_sensor.translation());

  const FrameIndex frames = detail::build_frame_index(in.scan_utimes, tr.gt, rep.warnings);
  const std::set<std::int64_t> kf = detail::select_keyframe_utimes(in, frames, rep.warnings);
  tr.corrected = detail::corrected_trajectory(in.corrected);
  rep.has_corrected = !tr.corrected.empty();
  const detail::RawKeyframePoses raw = detail::sample_keyframes(kf, tr, in, frames, config, rep);
  if (rep.keyframe_utimes.empty()) {
    rep.error = "no keyframe has both a ground-truth and an odometry pose (do the utimes of the two logs match?)";
    return rep;
  }
  detail::align_to_ground_truth(raw, rep);

  rep.loop_ground_truth = compute_loop_ground_truth(positions_of(rep.gt_keyframes), rep.keyframe_frames, config.ground_truth);
  const LoopTally tally = check_loops(in, tr.gt, frames, config, rep);
  if (!in.loops.empty() && tally.pr_dist.empty()) rep.warnings.push_back("no loop event carries a descriptor distance: no precision-recall curve");

  fill_detection_metrics(tally, rep.loop_ground_truth, rep.detection);
  fill_closure_metrics(tally, rep.loop_ground_truth, rep.closure);
  fill_pose_errors(rep);
  fill_loop_errors(in.loops, rep);
  fill_timings(in.loops, rep);
  fill_session_metrics(in, tr.gt, config, rep);
  rep.ok = true;
  return rep;
}

}  // namespace loopd
