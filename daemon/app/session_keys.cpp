#include "session_keys.hpp"

#include <algorithm>
#include <cmath>

namespace loopd {

std::optional<std::string> SessionPolicy::validate() const {
  if (!(resume_max_gap >= 0.0 && std::isfinite(resume_max_gap))) return "sessions.resume_max_gap must be a finite number >= 0 [s]";
  if (!(max_speed > 0.0) || !(min_jump >= 0.0)) return "sessions: max_speed must be > 0 and min_jump >= 0";
  return std::nullopt;
}

void SessionKeys::restore(const std::vector<KeyframeKey>& keys, const std::vector<std::int64_t>& utimes, const Eigen::Isometry3d& T_odom_newest,
                          bool skip_stored) {
  stored_keys_ = keys;
  stored_utimes_ = utimes;
  stored_at_utime_.clear();
  for (std::size_t i = 0; i < utimes.size() && i < keys.size(); ++i) stored_at_utime_.emplace(utimes[i], i);
  max_session_ = std::max<SessionId>(max_session_, policy_.first_session - 1);
  for (const KeyframeKey& k : keys) max_session_ = std::max(max_session_, k.session);
  T_odom_newest_ = T_odom_newest;
  skip_stored_ = skip_stored && !keys.empty();
}

void SessionKeys::on_odometry_reset(std::int64_t utime, const Eigen::Isometry3d& T_continuous_odom) { resets_.push_back({utime, T_continuous_odom}); }

void SessionKeys::open_session(const std::string& why, Assigned& out) {
  session_ = ++max_session_;
  next_index_ = 0;
  chosen_ = true;
  ++sessions_opened_;
  out.note = "session " + std::to_string(session_) + " opened: " + why;
}

void SessionKeys::choose(std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, Assigned& out) {
  if (stored_keys_.empty()) {  // a new map (or none): the first session
    session_ = std::max<SessionId>(max_session_, policy_.first_session);
    max_session_ = session_;
    chosen_ = true;
    return;
  }
  const KeyframeKey& newest = stored_keys_.back();
  const double dt = static_cast<double>(utime - stored_utimes_.back()) * 1e-6;
  const double moved = (T_odom_newest_.inverse() * T_odom_sensor).translation().norm();
  if (dt > 0.0 && dt <= policy_.resume_max_gap && moved <= std::max(policy_.min_jump, policy_.max_speed * dt)) {
    session_ = newest.session;  // the same odometry, a moment later: loopd restarted mid-drive
    next_index_ = newest.index + 1;
    chosen_ = true;
    out.note =
        "continuing session " + std::to_string(session_) + " (its odometry goes on " + std::to_string(dt) + " s after the map's newest keyframe)";
    return;
  }
  open_session("a drive the map's newest session does not continue (" + std::to_string(dt) + " s and " + std::to_string(moved) +
                   " m after its newest keyframe): unanchored until a loop ties it to the map",
               out);
}

SessionKeys::Assigned SessionKeys::assign(std::int64_t utime, const Eigen::Isometry3d& T_continuous_sensor) {
  Assigned out;
  // The odometry segment this scan belongs to.
  for (; next_reset_ < resets_.size() && resets_[next_reset_].utime <= utime; ++next_reset_) {
    T_continuous_odom_ = resets_[next_reset_].T_continuous_odom;
    reset_pending_ = policy_.new_session_on_reset;
  }
  out.T_odom_sensor = policy_.new_session_on_reset ? T_continuous_odom_.inverse() * T_continuous_sensor : T_continuous_sensor;
  if (skip_stored_) {
    const auto it = stored_at_utime_.find(utime);
    if (it != stored_at_utime_.end() && it->second >= next_stored_) {
      // Replay resume: the same drive selects the same keyframes again; the map holds this one.
      next_stored_ = it->second + 1;
      out.stored = true;
      out.key = stored_keys_[it->second];
      session_ = out.key.session;
      next_index_ = out.key.index + 1;
      chosen_ = matched_stored_ = true;
      reset_pending_ = false;
      ++skipped_;
      return out;
    }
    skip_stored_ = false;
    if (matched_stored_)
      out.note = "keyframe at utime " + std::to_string(utime) +
                 " is not the map's next one: not the drive the map was made from; the rest is added after it";
  }
  if (reset_pending_ && chosen_) open_session("the odometry restarted (a jump the vehicle cannot have made)", out);
  reset_pending_ = false;
  if (!chosen_) choose(utime, out.T_odom_sensor, out);
  out.key = KeyframeKey{session_, next_index_++};
  return out;
}

}  // namespace loopd
