#include "loopd/runtime/view_sink.hpp"

#include <deque>

namespace loopd {

void ViewSink::on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) {
  const bool cloud = keyframe.features && !keyframe.features->prepared.points.empty();
  feed_.add_keyframe(keyframe.key, keyframe.utime, keyframe.T_odom_sensor, T_map_sensor, cloud ? &keyframe.features->prepared.points : nullptr);
  next_.on_keyframe(keyframe, T_map_sensor, map_cloud);
}

void ViewSink::on_decision(const LoopDecision& decision) {
  feed_.add_decision(decision);
  next_.on_decision(decision);
}

void ViewSink::on_correction(const CorrectionOutput& correction) {
  feed_.set_correction(correction.revision, correction.keys, correction.T_map_sensor);
  next_.on_correction(correction);
}

void ViewSink::on_final_correction(const CorrectionOutput& correction) {
  feed_.set_correction(correction.revision, correction.keys, correction.T_map_sensor);
  next_.on_final_correction(correction);
}

StoreStatus load_map_view(MapStore& store, ViewFeed& feed, const MapViewOptions& options) {
  std::deque<std::pair<KeyframeKey, Eigen::Isometry3d>> newest;  // the newest keyframes that may have a map cloud
  StoreStatus status = store.for_each_keyframe(std::nullopt, KeyframeLoad::kPose, [&](MapKeyframe&& k) {
    feed.add_map_keyframe(k.record.key, k.record.utime, k.record.T_odom_sensor, k.T_map_sensor);
    if (!k.retired && options.clouds > 0) {
      newest.emplace_back(k.record.key, k.record.T_odom_sensor);
      if (static_cast<int>(newest.size()) > options.clouds) newest.pop_front();
    }
  });
  if (!status.ok()) return status;
  const StoreResult<std::optional<CorrectionRecord>> correction = store.correction();
  if (!correction.ok()) return correction.status;
  if (correction.value) feed.set_correction(correction.value->revision, correction.value->keys, correction.value->T_map_sensor);
  if (options.decisions) {
    status = store.for_each_loop(false, [&](LoopDecision&& d) { feed.add_decision(d); });
    if (!status.ok()) return status;
  }
  for (const auto& [key, T_odom_sensor] : newest) {
    const StoreResult<PointCloud> cloud = store.get_map_cloud(key);
    if (cloud.ok()) feed.add_cloud(key, T_odom_sensor, cloud.value.points);  // none (kNotFound): a map made without clouds
  }
  return StoreStatus{};
}

}  // namespace loopd
