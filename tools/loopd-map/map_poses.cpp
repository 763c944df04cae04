#include "map_poses.hpp"

#include <map>

#include "tool_output.hpp"

namespace loopd::tools {

StoreStatus read_keyframe_poses(MapStore& store, bool odometry, std::optional<SessionId> session, bool progress, KeyframePoses* out) {
  const StoreResult<std::optional<CorrectionRecord>> correction = store.correction();
  if (!correction.ok()) return correction.status;
  const CorrectionRecord* stored = correction.value ? &*correction.value : nullptr;
  out->correction_revision = stored ? stored->revision : 0;
  std::map<KeyframeKey, std::size_t> covered;
  if (stored && !odometry)
    for (std::size_t i = 0; i < stored->keys.size(); ++i) covered.emplace(stored->keys[i], i);
  const StoreResult<MapStats> stats = store.stats();
  Progress bar("reading keyframes", stats.ok() ? stats.value.keyframes : 0, progress);
  const StoreStatus read = store.for_each_keyframe(session, KeyframeLoad::kPose, [&](MapKeyframe&& k) {
    KeyframePose p{k.record.key, k.record.utime, k.record.T_odom_sensor, k.retired};
    if (!odometry) {
      const auto it = covered.find(k.record.key);
      if (it != covered.end()) {
        p.T = stored->T_map_sensor[it->second];
        ++out->from_correction;
      } else {
        p.T = stored ? stored->T_map_odom * k.record.T_odom_sensor : k.record.T_odom_sensor;
        ++out->after_correction;
      }
    }
    out->poses.push_back(p);
    bar.update(static_cast<std::int64_t>(out->poses.size()));
  });
  bar.finish();
  return read;
}

}  // namespace loopd::tools
