#include "trajectory_publisher.hpp"

#include <cmath>

#include "output_messages.hpp"

namespace loopd {

bool TrajectoryPublisher::snapshot_due(const CorrectionOutput& c, std::int64_t utime) const {
  if (!last_snapshot_utime_ || config_.snapshot_period <= 0.0) return true;
  // A clock that went backwards (live clock jump) restarts the period.
  if (utime < *last_snapshot_utime_ || static_cast<double>(utime - *last_snapshot_utime_) >= config_.snapshot_period * 1e6) return true;
  // Keyframes removed or reordered: a consumer keyed by id cannot follow a partial message.
  if (c.keys.size() < published_keys_.size()) return true;
  for (std::size_t i = 0; i < published_keys_.size(); ++i)
    if (c.keys[i] != published_keys_[i]) return true;
  return false;
}

bool TrajectoryPublisher::moved(std::size_t i, const Eigen::Isometry3d& T_map_sensor) const {
  if (i >= published_poses_.size()) return true;
  const Eigen::Isometry3d& before = published_poses_[i];
  if ((T_map_sensor.translation() - before.translation()).squaredNorm() > config_.min_move * config_.min_move) return true;
  // The turn between them from the trace of R_before^T R (1 + 2 cos(angle)), without a rotation-to-axis conversion
  // per keyframe: this runs over every keyframe of every revision.
  const double cos_turn = 0.5 * ((before.linear().cwiseProduct(T_map_sensor.linear())).sum() - 1.0);
  return cos_turn < min_turn_cos_;
}

trajectory_t TrajectoryPublisher::build(const CorrectionOutput& c, std::int64_t utime, bool full) {
  trajectory_t m = to_message_header(c, utime);
  const std::size_t n = c.T_map_sensor.size();
  if (full) {
    published_keys_.clear();
    published_poses_.clear();
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!full && !moved(i, c.T_map_sensor[i])) continue;
    const KeyframeKey key = i < c.keys.size() ? c.keys[i] : KeyframeKey{0, static_cast<std::int64_t>(i)};
    m.keyframes.push_back(to_keyframe_pose(key.index, i < c.utimes.size() ? c.utimes[i] : 0, c.T_map_sensor[i]));
    m.keyframe_sessions.push_back(key.session);
    if (i < published_poses_.size()) {
      published_poses_[i] = c.T_map_sensor[i];
    } else {
      published_keys_.push_back(key);
      published_poses_.push_back(c.T_map_sensor[i]);
    }
  }
  m.num_keyframes = static_cast<std::int32_t>(m.keyframes.size());
  m.full = full;
  m.total_keyframes = static_cast<std::int64_t>(n);
  if (full) last_snapshot_utime_ = utime;
  last_was_full_ = full;
  ++stats_.messages;
  stats_.snapshots += full ? 1 : 0;
  stats_.keyframes += m.num_keyframes;
  return m;
}

void TrajectoryPublisher::remember(const CorrectionOutput& correction) {
  last_.revision = correction.revision;
  last_.loop_event_id = correction.loop_event_id;
  last_.method = correction.method;
  last_.keys = correction.keys;
  last_.utimes = correction.utimes;
  last_.T_map_sensor = correction.T_map_sensor;
  last_.T_map_odom = correction.T_map_odom;
  last_.sessions = correction.sessions;
}

trajectory_t TrajectoryPublisher::make_message(const CorrectionOutput& correction, std::int64_t utime) {
  remember(correction);
  return build(correction, utime, snapshot_due(correction, utime));
}

trajectory_t TrajectoryPublisher::final_message(const CorrectionOutput& correction, std::int64_t utime) {
  remember(correction);
  return build(correction, utime, true);
}

std::optional<trajectory_t> TrajectoryPublisher::final_snapshot(std::int64_t utime) {
  if (last_was_full_) return std::nullopt;
  return build(last_, utime, true);
}

}  // namespace loopd
