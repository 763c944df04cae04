#include "loopd/runtime/session_keys.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace loopd {
namespace {
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
}  // namespace

std::optional<std::string> SessionPolicy::validate() const {
  if (!(resume_max_gap >= 0.0 && std::isfinite(resume_max_gap))) return "sessions.resume_max_gap must be a finite number >= 0 [s]";
  if (!(max_speed > 0.0) || !(min_jump >= 0.0)) return "sessions: max_speed must be > 0 and min_jump >= 0";
  return std::nullopt;
}

void SessionKeys::restore(std::vector<StoredKeyframe> keyframes, bool skip_stored) {
  stored_ = std::move(keyframes);
  stored_at_utime_.clear();
  stored_newest_index_.clear();
  max_session_ = std::max<SessionId>(max_session_, policy_.first_session - 1);
  for (std::size_t i = 0; i < stored_.size(); ++i) {
    const KeyframeKey& k = stored_[i].key;
    stored_at_utime_.emplace(stored_[i].utime, i);
    std::int64_t& newest = stored_newest_index_.try_emplace(k.session, k.index).first->second;
    newest = std::max(newest, k.index);
    max_session_ = std::max(max_session_, k.session);
  }
  skip_stored_ = skip_stored && !stored_.empty();
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
  if (stored_.empty()) {  // a new map (or none): the first session
    session_ = std::max<SessionId>(max_session_, policy_.first_session);
    max_session_ = session_;
    chosen_ = true;
    return;
  }
  const KeyframeKey& newest = stored_.back().key;
  const double dt = static_cast<double>(utime - stored_.back().utime) * 1e-6;
  const double moved = (stored_.back().T_odom_sensor.inverse() * T_odom_sensor).translation().norm();
  if (dt > 0.0 && dt <= policy_.resume_max_gap && moved <= std::max(policy_.min_jump, policy_.max_speed * dt)) {
    session_ = newest.session;  // the same odometry, a moment later: loopd restarted mid-drive
    next_index_ = newest.index + 1;
    chosen_ = true;
    out.note = "continuing session " + std::to_string(session_) + " (its odometry goes on " + fixed(dt, 1) + " s after the map's newest keyframe)";
    return;
  }
  if (dt <= 0.0)
    open_session("another drive within the time of the map's drives (its first keyframe " + fixed(-dt, 1) +
                     " s before the map's newest, and none of the map's keyframes): unanchored until a loop ties it to the map",
                 out);
  else
    open_session("a drive the map's newest session does not continue (" + fixed(dt, 1) + " s and " + fixed(moved, 1) +
                     " m after its newest keyframe): unanchored until a loop ties it to the map",
                 out);
}

std::optional<std::size_t> SessionKeys::match_stored(std::int64_t utime, const Eigen::Isometry3d& T_odom_sensor, std::uint64_t fingerprint) const {
  const auto [first, last] = stored_at_utime_.equal_range(utime);
  for (auto it = first; it != last; ++it) {
    const StoredKeyframe& k = stored_[it->second];
    // In order: a stored session's first keyframe, then that session's next (or, after an odometry reset, the first
    // of a later session).
    const bool in_order = !last_matched_
                              ? k.key.index == 0
                              : (k.key.session == session_ && k.key.index == next_index_) || (k.key.index == 0 && k.key.session > session_);
    if (!in_order) continue;
    if (fingerprint != 0 && k.scan_fingerprint != 0 && fingerprint != k.scan_fingerprint) continue;
    const Eigen::Isometry3d delta = k.T_odom_sensor.inverse() * T_odom_sensor;
    if (delta.translation().norm() > 1e-3 || Eigen::AngleAxisd(delta.linear()).angle() > 1e-2 * M_PI / 180.0) continue;
    return it->second;
  }
  return std::nullopt;
}

void SessionKeys::leave_stored(std::int64_t utime, Assigned& out) {
  skip_stored_ = false;
  if (!last_matched_) return;  // not the map's drive at all: choose() places it
  const KeyframeKey& last = stored_[*last_matched_].key;
  if (stored_newest_index_.at(last.session) == last.index) {
    out.note = "replay resumed on its map: " + std::to_string(skipped_) + " keyframes the map holds skipped, session " +
               std::to_string(last.session) + " goes on from keyframe " + to_string(last);
    return;
  }
  // The map's drive up to here, then something else (another keyframe config, another log from the same start): the
  // stored session holds keys past this point, so the rest is a session of its own.
  open_session("keyframe at utime " + std::to_string(utime) + " is not the map's next one (after " + to_string(last) +
                   ", which is not its session's newest): the rest of this drive is unanchored until a loop ties it to the map",
               out);
}

SessionKeys::Assigned SessionKeys::assign(std::int64_t utime, const Eigen::Isometry3d& T_continuous_sensor, std::uint64_t scan_fingerprint) {
  Assigned out;
  // The odometry segment this scan belongs to.
  for (; next_reset_ < resets_.size() && resets_[next_reset_].utime <= utime; ++next_reset_) {
    T_continuous_odom_ = resets_[next_reset_].T_continuous_odom;
    reset_pending_ = policy_.new_session_on_reset;
  }
  out.T_odom_sensor = policy_.new_session_on_reset ? T_continuous_odom_.inverse() * T_continuous_sensor : T_continuous_sensor;
  if (skip_stored_) {
    if (const std::optional<std::size_t> i = match_stored(utime, out.T_odom_sensor, scan_fingerprint)) {
      // Replay resume: the same drive selects the same keyframes again; the map holds this one.
      last_matched_ = *i;
      out.stored = true;
      out.key = stored_[*i].key;
      session_ = out.key.session;
      next_index_ = out.key.index + 1;
      chosen_ = true;
      reset_pending_ = false;
      ++skipped_;
      return out;
    }
    leave_stored(utime, out);
  }
  if (reset_pending_ && chosen_) open_session("the odometry restarted (a jump the vehicle cannot have made)", out);
  reset_pending_ = false;
  if (!chosen_) choose(utime, out.T_odom_sensor, out);
  out.key = KeyframeKey{session_, next_index_++};
  return out;
}

}  // namespace loopd
