#include "loopd/runtime/localization_tracker.hpp"

#include <algorithm>

namespace loopd {

void LocalizationTracker::on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor) {
  LocalizationState s;
  s.keyframe = keyframe.key;
  s.utime = keyframe.utime;
  s.T_map_sensor = T_map_sensor;
  pending_ = s;
  T_odom_sensor_ = keyframe.T_odom_sensor;
}

void LocalizationTracker::on_decision(const LoopDecision& decision) {
  if (!decision.accepted() || decision.query.session == decision.match.session) return;
  ++loops_to_map_;
  last_loop_utime_ = std::max(last_loop_utime_, decision.query_utime);
}

void LocalizationTracker::on_correction(const CorrectionOutput& correction) {
  if (!pending_) return;  // between keyframes (the loop ledger): the next keyframe is placed by it
  const auto key = std::find(correction.keys.begin(), correction.keys.end(), pending_->keyframe);
  if (key != correction.keys.end()) pending_->T_map_sensor = correction.T_map_sensor[static_cast<std::size_t>(key - correction.keys.begin())];
  const auto session = std::find_if(correction.sessions.begin(), correction.sessions.end(),
                                    [&](const SessionAlignment& a) { return a.session == pending_->keyframe.session; });
  if (!localized_ && session != correction.sessions.end() && session->anchored) {
    localized_ = true;
    localized_since_utime_ = pending_->utime;
  }
}

std::optional<LocalizationState> LocalizationTracker::on_keyframe_decided(const KeyframeKey& key) {
  if (!pending_ || !(pending_->keyframe == key)) return std::nullopt;
  LocalizationState s = *pending_;
  pending_.reset();
  s.localized = localized_;
  s.localized_since_utime = localized_since_utime_;
  s.loops_to_map = loops_to_map_;
  s.last_loop_utime = last_loop_utime_;
  s.T_map_odom = s.T_map_sensor * T_odom_sensor_.inverse();
  return s;
}

}  // namespace loopd
