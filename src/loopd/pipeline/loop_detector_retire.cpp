// Area-bounded maps: the place views the retirement policy ranks, and retiring a keyframe from every candidate list.
#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

PlaceKeyframe LoopDetector::view_of(const KeyframeRecord& record) const {
  PlaceKeyframe view;
  view.key = record.key;
  view.T_map_sensor = corrected(record.key);
  view.travelled = record.travelled;
  const auto loops = loop_ends_.find(record.key);
  view.loops = loops == loop_ends_.end() ? 0 : loops->second;
  return view;
}

std::optional<PlaceKeyframe> LoopDetector::place_view(const KeyframeKey& key) const {
  const KeyframeRecord* record = keyframes_.find(key);
  if (!record) return std::nullopt;
  return view_of(*record);
}

std::vector<PlaceKeyframe> LoopDetector::place_views_near(const KeyframeKey& key, double radius) const {
  std::vector<PlaceKeyframe> out;
  if (!keyframes_.find(key)) return out;
  for (const GateCandidate& c : gate_.within(corrected(key).translation(), radius)) {
    if (c.key == key) continue;
    const KeyframeRecord* record = keyframes_.find(c.key);
    if (!record || !record->features) continue;  // shed: never a candidate either
    if (c.key.session != key.session && !sessions_.tied(c.key.session, key.session)) continue;
    out.push_back(view_of(*record));
  }
  return out;
}

bool LoopDetector::retire_keyframe(const KeyframeKey& key) {
  const std::optional<std::size_t> slot = keyframes_.drop_features(key);
  if (!slot) return false;
  places_.remove(key);
  if (cache_) cache_->erase(key);
  // The gate holds one entry per keyframe record, in the same order (place_keyframe, restore_keyframe).
  if (gate_.size() == keyframes_.size()) gate_.retire(*slot);
  ++retired_keyframes_;
  return true;
}

}  // namespace loopd
