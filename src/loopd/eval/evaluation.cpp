#include "loopd/eval/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

namespace loopd {
namespace {

bool has_descriptor(const LoopRecord& r) {
  return std::isfinite(r.descriptor_distance) && r.descriptor_distance >= 0.0 && r.stage != "gate";
}

int status_rank(LoopStatus s) {
  switch (s) {
    case LoopStatus::kAccepted: return 2;
    case LoopStatus::kRejected: return 1;
    default: return 0;
  }
}

TimingStats timing_stats(const std::vector<LoopRecord>& loops, double LoopRecord::*field) {
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

/// @brief A copy of `poses` sorted by utime (stable: poses with equal stamps keep their order).
std::vector<StampedPose> sorted_by_time(const std::vector<StampedPose>& poses) {
  std::vector<StampedPose> sorted = poses;
  std::stable_sort(sorted.begin(), sorted.end(), [](const StampedPose& a, const StampedPose& b) { return a.utime < b.utime; });
  return sorted;
}

/// @brief Frame numbers: index of the scan in the drive (Vlaminck 2019, 5.3 counts poses of the sequence).
struct FrameIndex {
  std::vector<std::pair<std::int64_t, std::int64_t>> entries;  ///< (utime [us], frame), sorted; never empty

  /// @brief Frame of the scan nearest in time to `utime` (the later one on a tie).
  std::int64_t frame_of(std::int64_t utime) const {
    auto it = std::lower_bound(entries.begin(), entries.end(), std::make_pair(utime, std::int64_t{-1}));
    if (it == entries.end()) return std::prev(it)->second;
    if (it != entries.begin() && utime - std::prev(it)->first < it->first - utime) return std::prev(it)->second;
    return it->second;
  }
};

/// @brief Frames from the drive's scans, or from the ground-truth poses (`gt`, sorted) when the drive has no scans.
FrameIndex build_frame_index(const std::vector<std::int64_t>& scan_utimes, const std::vector<StampedPose>& gt,
                             std::vector<std::string>& warnings) {
  FrameIndex index;
  if (!scan_utimes.empty()) {
    for (std::size_t i = 0; i < scan_utimes.size(); ++i) index.entries.emplace_back(scan_utimes[i], static_cast<std::int64_t>(i));
  } else {
    warnings.push_back("no scans in the drive: frames are counted on ground-truth poses");
    for (std::size_t i = 0; i < gt.size(); ++i) index.entries.emplace_back(gt[i].utime, static_cast<std::int64_t>(i));
  }
  std::sort(index.entries.begin(), index.entries.end());
  return index;
}

/// @brief The trajectory's typical keyframe spacing in frames: the median gap between its keyframes' frames (>= 1).
std::int64_t keyframe_spacing(const std::vector<KeyframePose>& corrected, const FrameIndex& frames) {
  std::vector<std::int64_t> kf_frames;
  for (const auto& k : corrected) kf_frames.push_back(frames.frame_of(k.utime));
  std::sort(kf_frames.begin(), kf_frames.end());
  std::vector<std::int64_t> gaps;
  for (std::size_t i = 1; i < kf_frames.size(); ++i)
    if (kf_frames[i] > kf_frames[i - 1]) gaps.push_back(kf_frames[i] - kf_frames[i - 1]);
  std::int64_t spacing = 1;
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
    spacing = std::max<std::int64_t>(1, gaps[gaps.size() / 2]);
  }
  return spacing;
}

/// @brief After the last revision (which does not list later keyframes), the scans at the trajectory's typical
/// keyframe spacing are keyframes too.
void add_keyframes_after_last_revision(const std::vector<KeyframePose>& corrected, const FrameIndex& frames,
                                       std::set<std::int64_t>& kf, std::vector<std::string>& warnings) {
  const std::int64_t spacing = keyframe_spacing(corrected, frames);
  std::int64_t last_kf_utime = 0;
  for (const auto& k : corrected) last_kf_utime = std::max(last_kf_utime, k.utime);
  int added = 0;
  for (std::int64_t f = frames.frame_of(last_kf_utime) + spacing; f < static_cast<std::int64_t>(frames.entries.size());
       f += spacing) {
    // entries are sorted by utime, and frames are drive order, so entry f is frame f for increasing scans.
    const std::int64_t u = frames.entries[static_cast<std::size_t>(f)].first;
    if (u > last_kf_utime) {
      kf.insert(u);
      ++added;
    }
  }
  if (added > 0)
    warnings.push_back("the last trajectory revision ends before the drive: " + std::to_string(added) +
                       " later scans taken as keyframes (every " + std::to_string(spacing) + " scans)");
}

/// @brief Keyframes: the corrected trajectory's keyframes, the ends of every loop, and after the last revision the
/// scans at the trajectory's typical keyframe spacing; every scan when there is no corrected trajectory.
std::set<std::int64_t> select_keyframe_utimes(const EvalInput& in, const FrameIndex& frames, std::vector<std::string>& warnings) {
  std::set<std::int64_t> kf;
  for (const auto& k : in.corrected) kf.insert(k.utime);
  for (const auto& l : in.loops) {
    kf.insert(l.query_utime);
    kf.insert(l.match_utime);
  }
  if (!in.corrected.empty()) {
    add_keyframes_after_last_revision(in.corrected, frames, kf, warnings);
  } else {
    warnings.push_back("no CORRECTED_TRAJECTORY in the results: every scan counts as a keyframe for recall, and "
                       "'after' equals odometry");
    for (const auto& fi : frames.entries) kf.insert(fi.first);
  }
  return kf;
}

/// @brief The last trajectory revision as T_map_sensor stamped poses, sorted by utime.
std::vector<StampedPose> corrected_trajectory(const std::vector<KeyframePose>& keyframes) {
  std::vector<StampedPose> corrected;
  for (const auto& k : keyframes) {
    StampedPose p;
    p.utime = k.utime;
    p.T_world_sensor = k.T_map_sensor;
    corrected.push_back(p);
  }
  return sorted_by_time(corrected);
}

/// @brief The drive's trajectories, each sorted by utime.
struct SortedTrajectories {
  std::vector<StampedPose> gt;         ///< ground truth, T_world_sensor
  std::vector<StampedPose> odom;       ///< odometry, T_odom_sensor
  std::vector<StampedPose> corrected;  ///< last revision, T_map_sensor (empty without one)
};

/// @brief Odometry and corrected poses at the evaluated keyframes, before aligning them to ground truth.
struct RawKeyframePoses {
  std::vector<Eigen::Isometry3d> odom, after;
};

/// @brief Looks up ground truth, odometry and the corrected pose at every keyframe utime; keyframes without ground
/// truth or odometry are dropped (with a warning). Fills rep's keyframe_utimes, keyframe_frames and gt_keyframes.
RawKeyframePoses sample_keyframes(const std::set<std::int64_t>& kf, const SortedTrajectories& tr, const EvalInput& in,
                                  const FrameIndex& frames, const EvalConfig& config, EvalReport& rep) {
  const std::int64_t last_corrected = tr.corrected.empty() ? 0 : tr.corrected.back().utime;
  const std::int64_t gi = config.max_interpolation_gap_us, gn = config.max_nearest_gap_us;
  int no_gt = 0, no_odom = 0;
  RawKeyframePoses raw;
  for (std::int64_t u : kf) {
    const auto g = pose_at(tr.gt, u, gi, gn);
    if (!g) {
      ++no_gt;
      continue;
    }
    const auto o = pose_at(tr.odom, u, gi, gn);
    if (!o) {
      ++no_odom;
      continue;
    }
    std::optional<Eigen::Isometry3d> a;
    if (!tr.corrected.empty() && u <= last_corrected) a = pose_at(tr.corrected, u, gi, gn);
    if (!a) a = in.corrected.empty() ? *o : in.T_map_odom * *o;
    rep.keyframe_utimes.push_back(u);
    rep.keyframe_frames.push_back(frames.frame_of(u));
    rep.gt_keyframes.push_back(*g);
    raw.odom.push_back(*o);
    raw.after.push_back(*a);
  }
  if (no_gt > 0) rep.warnings.push_back(std::to_string(no_gt) + " keyframes without ground truth were dropped");
  if (no_odom > 0) rep.warnings.push_back(std::to_string(no_odom) + " keyframes without odometry were dropped");
  return raw;
}

/// @brief "Before" and "after" share the ground truth's frame by aligning their first keyframe to it.
void align_to_ground_truth(const RawKeyframePoses& raw, EvalReport& rep) {
  const Eigen::Isometry3d A_before = rep.gt_keyframes.front() * raw.odom.front().inverse();
  const Eigen::Isometry3d A_after = rep.gt_keyframes.front() * raw.after.front().inverse();
  for (std::size_t i = 0; i < raw.odom.size(); ++i) {
    rep.before_keyframes.push_back(A_before * raw.odom[i]);
    rep.after_keyframes.push_back(A_after * raw.after[i]);
  }
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

PairVerdicts pair_verdicts(const std::vector<LoopRecord>& loops) {
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
LoopCheck check_loop(std::size_t idx, const LoopRecord& l, const std::vector<std::int64_t>& keyframe_utimes,
                     const std::vector<StampedPose>& gt, const FrameIndex& frames, const EvalConfig& config) {
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
    c.true_loop = is_true_loop(gq->translation(), frames.frame_of(l.query_utime), gm->translation(),
                               frames.frame_of(l.match_utime), config.ground_truth);
    // Vlaminck 2019, 5.4 closes loops with T_match_query; the truth is GT_match^-1 * GT_query.
    const RelativeError e = relative_error(l.T_match_query, gm->inverse() * *gq);
    c.translation_error = e.translation;
    c.rotation_error_deg = e.rotation_deg;
  }
  return c;
}

/// @brief What the loop pairs add up to: the precision-recall inputs and the revisit keyframes they cover.
struct LoopTally {
  std::vector<double> pr_dist;  ///< best descriptor distance of each pair that has one
  std::vector<bool> pr_true;    ///< ... whether it is a true loop
  std::vector<int> pr_query;    ///< ... its query keyframe when that is a revisit, else -1
  std::set<int> covered_detect, covered_accept, covered_correct;  ///< revisit query keyframes with a true / any / correct accepted loop
};

/// @brief An accepted loop: closure correctness (Vlaminck 2019, 5.4), detection TP/FP and the revisits it covers.
void count_accepted(LoopCheck& c, bool q_revisit, const EvalConfig& config, EvalReport& rep, LoopTally& tally) {
  ++rep.closure.accepted;
  c.correct = c.has_ground_truth && c.translation_error <= config.closure_max_translation &&
              c.rotation_error_deg <= config.closure_max_rotation_deg;
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
LoopTally check_loops(const EvalInput& in, const std::vector<StampedPose>& gt, const FrameIndex& frames,
                      const EvalConfig& config, EvalReport& rep) {
  const PairVerdicts verdicts = pair_verdicts(in.loops);
  const LoopGroundTruth& lgt = rep.loop_ground_truth;
  LoopTally tally;
  for (const auto& [key, idx] : verdicts.decisive) {
    const LoopRecord& l = in.loops[idx];
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
    if (it != tally.covered_correct.end() && *it <= last) ++cm.stretches_closed;
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

/// @brief Per-stage timings over the loop events.
void fill_timings(const std::vector<LoopRecord>& loops, EvalReport& rep) {
  rep.ms_descriptor = timing_stats(loops, &LoopRecord::ms_descriptor);
  rep.ms_fourpcs = timing_stats(loops, &LoopRecord::ms_fourpcs);
  rep.ms_gicp = timing_stats(loops, &LoopRecord::ms_gicp);
  rep.ms_hungarian = timing_stats(loops, &LoopRecord::ms_hungarian);
  rep.ms_total = timing_stats(loops, &LoopRecord::ms_total);
}

}  // namespace

std::optional<std::string> EvalConfig::validate() const {
  if (auto e = ground_truth.validate()) return e;
  if (!(closure_max_translation > 0)) return "eval: closure_max_translation must be > 0 m";
  if (!(closure_max_rotation_deg > 0)) return "eval: closure_max_rotation_deg must be > 0 deg";
  if (max_interpolation_gap_us < 0 || max_nearest_gap_us < 0) return "eval: time gaps must be >= 0 us";
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
  SortedTrajectories tr;
  tr.gt = sorted_by_time(in.ground_truth);
  tr.odom = sorted_by_time(in.odometry);
  if (tr.gt.empty()) {
    rep.error = "no ground-truth poses in the drive";
    return rep;
  }
  for (const auto& p : tr.gt) rep.gt_path.push_back(p.T_world_sensor.translation());

  const FrameIndex frames = build_frame_index(in.scan_utimes, tr.gt, rep.warnings);
  const std::set<std::int64_t> kf = select_keyframe_utimes(in, frames, rep.warnings);
  tr.corrected = corrected_trajectory(in.corrected);
  rep.has_corrected = !tr.corrected.empty();
  const RawKeyframePoses raw = sample_keyframes(kf, tr, in, frames, config, rep);
  if (rep.keyframe_utimes.empty()) {
    rep.error = "no keyframe has both a ground-truth and an odometry pose (do the utimes of the two logs match?)";
    return rep;
  }
  align_to_ground_truth(raw, rep);

  rep.loop_ground_truth =
      compute_loop_ground_truth(positions_of(rep.gt_keyframes), rep.keyframe_frames, config.ground_truth);
  const LoopTally tally = check_loops(in, tr.gt, frames, config, rep);
  if (!in.loops.empty() && tally.pr_dist.empty())
    rep.warnings.push_back("no loop event carries a descriptor distance: no precision-recall curve");

  fill_detection_metrics(tally, rep.loop_ground_truth, rep.detection);
  fill_closure_metrics(tally, rep.loop_ground_truth, rep.closure);
  fill_pose_errors(rep);
  fill_timings(in.loops, rep);
  rep.ok = true;
  return rep;
}

}  // namespace loopd
