#include "trajectory_assembly.hpp"

namespace loopd {

bool TrajectoryAssembly::apply(const trajectory_t& msg) {
  if (applied_ > 0 && msg.revision < header_.revision) return false;
  if (msg.full) {
    keyframes_.clear();
    sessions_.clear();
    index_of_key_.clear();
    has_snapshot_ = true;
    ++snapshots_;
  }
  for (std::size_t i = 0; i < msg.keyframes.size(); ++i) {
    const keyframe_pose_t& k = msg.keyframes[i];
    const std::int32_t session = i < msg.keyframe_sessions.size() ? msg.keyframe_sessions[i] : 0;
    const auto it = index_of_key_.find({session, k.id});
    if (it != index_of_key_.end()) {
      keyframes_[it->second] = k;
    } else {
      index_of_key_.emplace(std::make_pair(session, k.id), keyframes_.size());
      keyframes_.push_back(k);
      sessions_.push_back(session);
    }
  }
  header_ = msg;
  header_.keyframes.clear();
  header_.keyframe_sessions.clear();
  header_.num_keyframes = 0;
  ++applied_;
  return true;
}

trajectory_t TrajectoryAssembly::current() const {
  trajectory_t m = header_;
  m.keyframes = keyframes_;
  m.keyframe_sessions = sessions_;
  m.num_keyframes = static_cast<std::int32_t>(keyframes_.size());
  m.full = true;
  return m;
}

bool decode_any_trajectory(const void* data, std::size_t size, trajectory_t* out, std::string* why) {
  const DecodeResult r = decode_bounded(data, size, DecodeLimits{}, out);
  if (r.ok) return true;
  if (decode_trajectory_v2(data, size, DecodeLimits{}, out).ok) return true;
  if (decode_trajectory_v1(data, size, DecodeLimits{}, out).ok) return true;
  if (why) *why = r.reason + " (byte " + std::to_string(r.offset) + ")";
  return false;
}

}  // namespace loopd
