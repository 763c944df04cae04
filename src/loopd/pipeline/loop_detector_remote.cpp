// LoopDetector: other vehicles' keyframes (a fleet on one shared map) as candidates of prior-free loops.
#include <cstdio>

#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

bool LoopDetector::add_remote_keyframe(KeyframeRecord record) {
  if (remote_.find(record.key) || pose_index_.count(record.key)) return false;
  remote_.note_session(record.key.session);
  const bool indexed = config_.retrieval.enabled && record.features && record.features->ok && record.features->place.ok &&
                       places_.add(record.key, record.features->place);
  if (!indexed) record.features = nullptr;  // a pose without a place descriptor is never a candidate
  if (cache_ && record.features) {
    if (!record.features->prepared_in_store) cache_->put(record.key, record.features);
    record.features = thinned(*record.features);
  }
  remote_.add(std::move(record));
  return true;
}

LoopDetector::RemoteOutcome LoopDetector::close_remote(const KeyframeRecord& query, const KeyframeFeatures& query_features,
                                                       const Eigen::Isometry3d& T_map_query, const PlaceCandidate& place, double radius,
                                                       DetectorOutput& out, const DecisionCallback& on_decided) {
  // No common frame with another vehicle's session: the full verification, and the loop links nothing here until the
  // next keyframes (or an earlier loop to the same session) agree on where that session lies. The joint correction
  // of the fleet then takes it (it is stored and published like any decision).
  const KeyframeRecord& match = *remote_.find(place.key);
  const RankedCandidate candidate{&match, -1.0, (match.features->descriptor - query.features->descriptor).norm()};
  LoopDecision d = make_decision(query, candidate, radius);
  d.retrieval = "global";
  d.place_distance = place.place_distance;
  const std::shared_ptr<const KeyframeFeatures> match_features = full_features(match);
  VerifyResult v;
  if (match_features)
    v = verify_candidate(query_features.prepared, match_features->prepared, std::nullopt, config_.verify);
  else
    v.reason = "the keyframe's features could not be read back from the map store";
  apply_verification(v, query.features->ms_descriptor, d);
  const bool accepted = v.accepted && confirm_remote(match, v, T_map_query, d);
  report(std::move(d), out, on_decided);
  if (accepted) {
    ++loops_accepted_;
    return RemoteOutcome::kAccepted;
  }
  ++loops_rejected_;
  return v.accepted ? RemoteOutcome::kHeld : RemoteOutcome::kRejected;
}

bool LoopDetector::confirm_remote(const KeyframeRecord& match, const VerifyResult& verification, const Eigen::Isometry3d& T_map_query,
                                  LoopDecision& decision) {
  PriorFreeLoop loop;
  loop.query = decision.query;
  loop.match_group = match.key.session;
  loop.correction = match.T_odom_sensor * verification.T_match_query * T_map_query.inverse();  // T_session_map
  loop.p_map_query = T_map_query.translation();
  loop.event_id = decision.event_id;
  char why[200];
  const std::optional<RemoteKeyframes::Placement>& known = remote_.placement(match.key.session);
  if (known) {
    PriorFreeLoop placed = loop;
    placed.correction = known->T_session_map;
    const auto [translation, rotation] = PriorFreeConfirmation::disagreement(placed, loop);
    if (translation <= config_.retrieval.confirm_translation && rotation <= config_.retrieval.confirm_rotation_deg) {
      std::snprintf(why, sizeof why, "inter-vehicle loop agrees with session %d's placement by event %lld within %.3f m / %.2f deg",
                    match.key.session, static_cast<long long>(known->event_id), translation, rotation);
      decision.reason = why;
      decision.confirmed = true;
      remote_.set_placement(match.key.session, {loop.correction, decision.event_id});
      return true;
    }
  }
  if (confirm_prior_free_loop(loop, decision)) {
    remote_.set_placement(match.key.session, {loop.correction, decision.event_id});
    return true;
  }
  return false;
}

}  // namespace loopd
