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
  auto by_time = [](const StampedPose& a, const StampedPose& b) { return a.utime < b.utime; };
  std::vector<StampedPose> gt = in.ground_truth, odom = in.odometry;
  std::stable_sort(gt.begin(), gt.end(), by_time);
  std::stable_sort(odom.begin(), odom.end(), by_time);
  if (gt.empty()) {
    rep.error = "no ground-truth poses in the drive";
    return rep;
  }
  for (const auto& p : gt) rep.gt_path.push_back(p.T_world_sensor.translation());

  // Frame numbers: index of the scan in the drive (Vlaminck 2019, 5.3 counts poses of the sequence).
  std::vector<std::pair<std::int64_t, std::int64_t>> frame_index;  // (utime, frame)
  if (!in.scan_utimes.empty()) {
    for (std::size_t i = 0; i < in.scan_utimes.size(); ++i)
      frame_index.emplace_back(in.scan_utimes[i], static_cast<std::int64_t>(i));
  } else {
    rep.warnings.push_back("no scans in the drive: frames are counted on ground-truth poses");
    for (std::size_t i = 0; i < gt.size(); ++i) frame_index.emplace_back(gt[i].utime, static_cast<std::int64_t>(i));
  }
  std::sort(frame_index.begin(), frame_index.end());
  auto frame_of = [&](std::int64_t utime) -> std::int64_t {
    auto it = std::lower_bound(frame_index.begin(), frame_index.end(), std::make_pair(utime, std::int64_t{-1}));
    if (it == frame_index.end()) return std::prev(it)->second;
    if (it != frame_index.begin() && utime - std::prev(it)->first < it->first - utime) return std::prev(it)->second;
    return it->second;
  };

  // Keyframes: the corrected trajectory's keyframes, the ends of every loop, and after the last revision the
  // scans at the trajectory's typical keyframe spacing (the last revision does not list later keyframes).
  std::set<std::int64_t> kf;
  for (const auto& k : in.corrected) kf.insert(k.utime);
  for (const auto& l : in.loops) {
    kf.insert(l.query_utime);
    kf.insert(l.match_utime);
  }
  if (!in.corrected.empty()) {
    std::vector<std::int64_t> frames;
    for (const auto& k : in.corrected) frames.push_back(frame_of(k.utime));
    std::sort(frames.begin(), frames.end());
    std::vector<std::int64_t> gaps;
    for (std::size_t i = 1; i < frames.size(); ++i)
      if (frames[i] > frames[i - 1]) gaps.push_back(frames[i] - frames[i - 1]);
    std::int64_t spacing = 1;
    if (!gaps.empty()) {
      std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
      spacing = std::max<std::int64_t>(1, gaps[gaps.size() / 2]);
    }
    std::int64_t last_kf_utime = 0;
    for (const auto& k : in.corrected) last_kf_utime = std::max(last_kf_utime, k.utime);
    int added = 0;
    for (std::int64_t f = frame_of(last_kf_utime) + spacing; f < static_cast<std::int64_t>(frame_index.size());
         f += spacing) {
      // frame_index is sorted by utime, and frames are drive order, so entry f is frame f for increasing scans.
      const std::int64_t u = frame_index[static_cast<std::size_t>(f)].first;
      if (u > last_kf_utime) {
        kf.insert(u);
        ++added;
      }
    }
    if (added > 0)
      rep.warnings.push_back("the last trajectory revision ends before the drive: " + std::to_string(added) +
                             " later scans taken as keyframes (every " + std::to_string(spacing) + " scans)");
  } else {
    rep.warnings.push_back("no CORRECTED_TRAJECTORY in the results: every scan counts as a keyframe for recall, and "
                           "'after' equals odometry");
    for (const auto& fi : frame_index) kf.insert(fi.first);
  }

  std::vector<StampedPose> corrected;
  for (const auto& k : in.corrected) {
    StampedPose p;
    p.utime = k.utime;
    p.T_world_sensor = k.T_map_sensor;
    corrected.push_back(p);
  }
  std::stable_sort(corrected.begin(), corrected.end(), by_time);
  rep.has_corrected = !corrected.empty();
  const std::int64_t last_corrected = corrected.empty() ? 0 : corrected.back().utime;

  const std::int64_t gi = config.max_interpolation_gap_us, gn = config.max_nearest_gap_us;
  int no_gt = 0, no_odom = 0;
  std::vector<Eigen::Isometry3d> odom_raw, after_raw;
  for (std::int64_t u : kf) {
    const auto g = pose_at(gt, u, gi, gn);
    if (!g) {
      ++no_gt;
      continue;
    }
    const auto o = pose_at(odom, u, gi, gn);
    if (!o) {
      ++no_odom;
      continue;
    }
    std::optional<Eigen::Isometry3d> a;
    if (!corrected.empty() && u <= last_corrected) a = pose_at(corrected, u, gi, gn);
    if (!a) a = in.corrected.empty() ? *o : in.T_map_odom * *o;
    rep.keyframe_utimes.push_back(u);
    rep.keyframe_frames.push_back(frame_of(u));
    rep.gt_keyframes.push_back(*g);
    odom_raw.push_back(*o);
    after_raw.push_back(*a);
  }
  if (no_gt > 0) rep.warnings.push_back(std::to_string(no_gt) + " keyframes without ground truth were dropped");
  if (no_odom > 0) rep.warnings.push_back(std::to_string(no_odom) + " keyframes without odometry were dropped");
  if (rep.keyframe_utimes.empty()) {
    rep.error = "no keyframe has both a ground-truth and an odometry pose (do the utimes of the two logs match?)";
    return rep;
  }
  // "Before" and "after" share the ground truth's frame by aligning their first keyframe to it.
  const Eigen::Isometry3d A_before = rep.gt_keyframes.front() * odom_raw.front().inverse();
  const Eigen::Isometry3d A_after = rep.gt_keyframes.front() * after_raw.front().inverse();
  for (std::size_t i = 0; i < odom_raw.size(); ++i) {
    rep.before_keyframes.push_back(A_before * odom_raw[i]);
    rep.after_keyframes.push_back(A_after * after_raw[i]);
  }

  rep.loop_ground_truth =
      compute_loop_ground_truth(positions_of(rep.gt_keyframes), rep.keyframe_frames, config.ground_truth);
  const LoopGroundTruth& lgt = rep.loop_ground_truth;
  auto keyframe_index = [&](std::int64_t u) -> int {
    auto it = std::lower_bound(rep.keyframe_utimes.begin(), rep.keyframe_utimes.end(), u);
    if (it == rep.keyframe_utimes.end() || *it != u) return -1;
    return static_cast<int>(it - rep.keyframe_utimes.begin());
  };

  // One verdict per (query, match) pair: the decisive event is the accepted one, else rejected, else candidate.
  std::map<std::pair<std::int64_t, std::int64_t>, std::size_t> decisive;
  std::map<std::pair<std::int64_t, std::int64_t>, double> best_distance;
  for (std::size_t i = 0; i < in.loops.size(); ++i) {
    const auto& l = in.loops[i];
    const auto key = std::make_pair(l.query_utime, l.match_utime);
    auto it = decisive.find(key);
    if (it == decisive.end() || status_rank(l.status) >= status_rank(in.loops[it->second].status)) decisive[key] = i;
    if (has_descriptor(l)) {
      auto d = best_distance.find(key);
      if (d == best_distance.end() || l.descriptor_distance < d->second) best_distance[key] = l.descriptor_distance;
    }
  }
  std::vector<double> pr_dist;
  std::vector<bool> pr_true;
  std::vector<int> pr_query;
  std::set<int> covered_detect, covered_accept, covered_correct;
  const double rad_tol = config.closure_max_rotation_deg;
  for (const auto& [key, idx] : decisive) {
    const LoopRecord& l = in.loops[idx];
    LoopCheck c;
    c.loop = idx;
    c.query_keyframe = keyframe_index(l.query_utime);
    c.match_keyframe = keyframe_index(l.match_utime);
    const auto gq = pose_at(gt, l.query_utime, gi, gn);
    const auto gm = pose_at(gt, l.match_utime, gi, gn);
    c.frame_gap = std::abs(frame_of(l.query_utime) - frame_of(l.match_utime));
    if (gq && gm) {
      c.has_ground_truth = true;
      c.gt_distance = place_distance(gq->translation(), gm->translation(), config.ground_truth);
      c.true_loop = is_true_loop(gq->translation(), frame_of(l.query_utime), gm->translation(),
                                 frame_of(l.match_utime), config.ground_truth);
      // Vlaminck 2019, 5.4 closes loops with T_match_query; the truth is GT_match^-1 * GT_query.
      const RelativeError e = relative_error(l.T_match_query, gm->inverse() * *gq);
      c.translation_error = e.translation;
      c.rotation_error_deg = e.rotation_deg;
    }
    const bool q_revisit = c.query_keyframe >= 0 && lgt.revisit[static_cast<std::size_t>(c.query_keyframe)];
    if (l.status == LoopStatus::kAccepted) {
      ++rep.closure.accepted;
      c.correct = c.has_ground_truth && c.translation_error <= config.closure_max_translation &&
                  c.rotation_error_deg <= rad_tol;
      if (c.correct) ++rep.closure.correct;
      if (c.true_loop) {
        ++rep.detection.true_positives;
        if (q_revisit) covered_detect.insert(c.query_keyframe);
      } else {
        ++rep.detection.false_positives;
      }
      if (q_revisit) covered_accept.insert(c.query_keyframe);
      if (q_revisit && c.correct) covered_correct.insert(c.query_keyframe);
    }
    const auto bd = best_distance.find(key);
    if (bd != best_distance.end()) {
      pr_dist.push_back(bd->second);
      pr_true.push_back(c.true_loop);
      pr_query.push_back(q_revisit ? c.query_keyframe : -1);
    }
    rep.checks.push_back(c);
  }
  if (!in.loops.empty() && pr_dist.empty())
    rep.warnings.push_back("no loop event carries a descriptor distance: no precision-recall curve");

  DetectionMetrics& d = rep.detection;
  d.gt_queries = lgt.num_queries;
  d.gt_pairs = lgt.num_pairs;
  d.false_negatives = lgt.num_queries - static_cast<int>(covered_detect.size());
  const int predicted = d.true_positives + d.false_positives;
  d.precision = predicted > 0 ? static_cast<double>(d.true_positives) / predicted : 0.0;
  d.recall = lgt.num_queries > 0 ? static_cast<double>(covered_detect.size()) / lgt.num_queries : 0.0;
  d.f1 = (d.precision + d.recall) > 0 ? 2 * d.precision * d.recall / (d.precision + d.recall) : 0.0;
  d.pr_curve = precision_recall_curve(pr_dist, pr_true, pr_query, lgt.num_queries);
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

  ClosureMetrics& cm = rep.closure;
  cm.precision = cm.accepted > 0 ? static_cast<double>(cm.correct) / cm.accepted : 0.0;
  cm.recall = lgt.num_queries > 0 ? static_cast<double>(covered_accept.size()) / lgt.num_queries : 0.0;
  cm.recall_correct = lgt.num_queries > 0 ? static_cast<double>(covered_correct.size()) / lgt.num_queries : 0.0;
  cm.stretches = static_cast<int>(lgt.stretches.size());
  for (const auto& [first, last] : lgt.stretches) {
    auto it = covered_correct.lower_bound(first);
    if (it != covered_correct.end() && *it <= last) ++cm.stretches_closed;
  }
  cm.stretches_closed_share = cm.stretches > 0 ? static_cast<double>(cm.stretches_closed) / cm.stretches : 0.0;

  // Vlaminck 2019, Table 4: distance of every pose to its closest ground-truth pose.
  const auto before_p = positions_of(rep.before_keyframes);
  const auto after_p = positions_of(rep.after_keyframes);
  const auto gt_p = positions_of(rep.gt_keyframes);
  rep.error_before = error_stats(closest_pose_errors(before_p, rep.gt_path));
  rep.error_after = error_stats(closest_pose_errors(after_p, rep.gt_path));
  rep.ate_before = ate_rmse(before_p, gt_p);
  rep.ate_after = ate_rmse(after_p, gt_p);

  rep.ms_descriptor = timing_stats(in.loops, &LoopRecord::ms_descriptor);
  rep.ms_fourpcs = timing_stats(in.loops, &LoopRecord::ms_fourpcs);
  rep.ms_gicp = timing_stats(in.loops, &LoopRecord::ms_gicp);
  rep.ms_hungarian = timing_stats(in.loops, &LoopRecord::ms_hungarian);
  rep.ms_total = timing_stats(in.loops, &LoopRecord::ms_total);
  rep.ok = true;
  return rep;
}

}  // namespace loopd
