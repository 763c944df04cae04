// LoopDetector: resuming from what a map store holds (the engine reads the store; the detector never sees it).
#include "loopd/pipeline/loop_detector.hpp"

#include <algorithm>

namespace loopd {

void LoopDetector::restore_keyframe(const KeyframeRecord& record) {
  // The same placement as add_keyframe(), without candidates: sessions, travel, corrector, gate, place index.
  std::shared_ptr<const KeyframeFeatures> features = record.features && record.features->ok ? record.features : nullptr;
  KeyframeInput input;
  input.key = record.key;
  input.utime = record.utime;
  input.T_odom_sensor = record.T_odom_sensor;
  input.residual = record.residual;
  input.scan_fingerprint = record.scan_fingerprint;
  std::optional<MeasuredStep> step;
  const Eigen::Isometry3d T_map_query = enter_pose_sequence(input, features.get(), &record.step, &step);
  const KeyframeRecord& placed = place_keyframe(input, std::move(features), T_map_query, step);
  add_to_gate(placed, T_map_query.translation());
}

void LoopDetector::expect_decisions(const std::vector<LoopDecision>& cut_off) {
  for (const LoopDecision& d : cut_off) {
    expected_event_ids_[{d.query_utime, d.match}] = d.event_id;
    next_event_id_ = std::max(next_event_id_, d.event_id + 1);
  }
}

LoopConstraint LoopDetector::count_restored(const LoopDecision& decision, const Information6d& information) {
  next_event_id_ = std::max(next_event_id_, decision.event_id + 1);
  LoopConstraint loop;
  if (decision.status != LoopStatus::kAccepted) {
    ++loops_rejected_;
    return loop;
  }
  ++loops_accepted_;
  ++loop_ends_[decision.query];
  ++loop_ends_[decision.match];
  if (!pose_index_.count(decision.match)) return loop;  // to another vehicle's keyframe: the fleet's joint correction takes it
  last_accepted_ = decision.query;
  last_correction_event_id_ = std::max(last_correction_event_id_, decision.event_id);  // each such loop made a correction
  if (!sessions_.cannot_tie(decision.query.session, decision.match.session)) sessions_.tie(decision.query.session, decision.match.session);
  travelled_at_last_loop_ = travelled_;
  loop.query_index = pose_index(decision.query);
  loop.match_index = pose_index(decision.match);
  loop.T_match_query = decision.T_match_query;
  loop.information = information;
  loop.robust = !decision.confirmed;
  return loop;
}

void LoopDetector::restore_decision(const LoopDecision& decision, const Information6d& information, bool revoked) {
  const LoopConstraint loop = count_restored(decision, information);
  if (decision.status != LoopStatus::kAccepted || !pose_index_.count(decision.match) || corrector_.check_loop(loop)) return;
  if (revoked) {
    revoked_[decision.event_id] = loop;
    return;
  }
  restored_loops_.push_back(loop);
  restored_events_.push_back(decision.event_id);
}

std::optional<std::string> LoopDetector::resume_correction(std::int64_t revision, const std::vector<KeyframeKey>& keys,
                                                           const std::vector<Eigen::Isometry3d>& T_map_sensor, const CorrectorResumeState& state) {
  if (keys.size() != T_map_sensor.size() || keys.size() != keyframes_.size())
    return "stored correction has " + std::to_string(keys.size()) + " poses for " + std::to_string(keyframes_.size()) + " keyframes";
  std::vector<Eigen::Isometry3d> corrected(keys.size(), Eigen::Isometry3d::Identity());
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const auto it = pose_index_.find(keys[i]);
    if (it == pose_index_.end()) return "stored correction names keyframe " + to_string(keys[i]) + ", which the map does not hold";
    corrected[static_cast<std::size_t>(it->second)] = T_map_sensor[i];
  }
  if (auto why = corrector_.resume(restored_loops_, corrected, state)) return why;
  loop_events_ = std::move(restored_events_);
  restored_events_.clear();
  restored_loops_.clear();
  revision_ = revision;
  update_gate(0);
  return std::nullopt;
}

std::optional<CorrectionOutput> LoopDetector::reapply_loop(const LoopDecision& decision, const Information6d& information) {
  const LoopConstraint loop = count_restored(decision, information);
  if (decision.status != LoopStatus::kAccepted || !pose_index_.count(decision.match) || corrector_.check_loop(loop)) return std::nullopt;
  Stopwatch sw;
  const CorrectionResult result = corrector_.add_loop(loop);
  if (corrector_.loops().size() > loop_events_.size()) loop_events_.push_back(decision.event_id);
  if (!result.ok) return std::nullopt;
  CorrectionOutput c = correction_output(result, decision.event_id, sw);
  update_gate(result.moved_from);
  return c;
}

}  // namespace loopd
