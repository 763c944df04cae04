// Area-bounded maps: the place views the retirement policy ranks, and retiring a keyframe from every candidate list.
#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

std::optional<PlaceKeyframe> LoopDetector::place_view(const KeyframeKey& key) const {
  const KeyframeRecord* record = keyframes_.find(key);
  if (!record) return std::nullopt;
  PlaceKeyframe view;
  view.key = key;
  view.T_map_sensor = corrected(key);
  view.travelled = record->travelled;
  const auto loops = loop_ends_.find(key);
  view.loops = loops == loop_ends_.end() ? 0 : loops->second;
  return view;
}

std::vector<PlaceKeyframe> LoopDetector::place_views_near(const KeyframeKey& key, double radius) const {
  std::vector<PlaceKeyframe> out;
  if (!keyframes_.find(key)) return out;
  for (const GateCandidate& c : gate_.within(corrected(key).translation(), radius)) {
    if (c.key == key) continue;
    const KeyframeRecord* record = keyframes_.find(c.key);
    if (!record || !record->features) continue;  // shed: never a candidate either
    if (c.key.session != key.session && !sessions_.tied(c.key.session, key.session)) continue;
    if (std::optional<PlaceKeyframe> view = place_view(c.key)) out.push_back(std::move(*view));
  }
  return out;
}

bool LoopDetector::retire_keyframe(const KeyframeKey& key) {
  const std::optional<std::size_t> slot = keyframes_.slot(key);
  if (!slot || !keyframes_.drop_features(key)) return false;
  places_.remove(key);
  if (cache_) cache_->erase(key);
  // The gate holds one entry per keyframe record, in the same order (place_keyframe, restore_keyframe).
  if (gate_.size() == keyframes_.size()) gate_.retire(*slot);
  ++retired_keyframes_;
  return true;
}

}  // namespace loopd
