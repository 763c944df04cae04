// Which session a keyframe belongs to (SessionKeys): a drive on a map continues its newest session only when its
// odometry plainly goes on from it; another drive, or an odometry reset, opens a new session.
#include <catch2/catch.hpp>
#include <tuple>

#include "loopd/runtime/session_keys.hpp"

using namespace loopd;

namespace {
Eigen::Isometry3d at(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}
constexpr std::int64_t kSecond = 1000000;

/// Stored keyframes (key, utime, x); fingerprints 1000 + index unless given.
std::vector<StoredKeyframe> stored(const std::vector<std::tuple<KeyframeKey, std::int64_t, double>>& rows) {
  std::vector<StoredKeyframe> out;
  for (const auto& [key, utime, x] : rows) out.push_back({key, utime, at(x), static_cast<std::uint64_t>(1000 + out.size())});
  return out;
}
}  // namespace

TEST_CASE("session keys: a new map starts session 0, a drive that goes on from the map's newest keyframe continues it") {
  SessionKeys fresh{SessionPolicy{}};
  const SessionKeys::Assigned a = fresh.assign(5 * kSecond, at(0.0));
  CHECK(a.key == KeyframeKey{0, 0});
  CHECK(fresh.assign(6 * kSecond, at(2.0)).key == KeyframeKey{0, 1});

  SessionKeys restarted{SessionPolicy{}};  // loopd restarted 3 s later, 20 m on (a car at 25 km/h)
  restarted.restore(stored({{{0, 0}, 5 * kSecond, 0.0}, {{0, 1}, 6 * kSecond, 2.0}}), false);
  const SessionKeys::Assigned b = restarted.assign(9 * kSecond, at(22.0));
  CHECK(b.key == KeyframeKey{0, 2});
  CHECK(b.note.find("continuing session 0") == 0);
}

TEST_CASE("session keys: another day's drive, or one that starts far from the map's end, opens a new session") {
  SessionKeys next_day{SessionPolicy{}};
  next_day.restore(stored({{{0, 0}, 5 * kSecond, 0.0}, {{0, 1}, 6 * kSecond, 2.0}}), false);
  const SessionKeys::Assigned a = next_day.assign(6 * kSecond + 86400 * kSecond, at(0.0));
  CHECK(a.key == KeyframeKey{1, 0});
  CHECK(a.note.find("session 1 opened") == 0);
  CHECK(next_day.assign(6 * kSecond + 86401 * kSecond, at(2.0)).key == KeyframeKey{1, 1});

  SessionKeys far{SessionPolicy{}};  // 1 s later but 500 m away: not the same odometry
  far.restore(stored({{{0, 0}, 5 * kSecond, 0.0}, {{2, 7}, 6 * kSecond, 2.0}}), false);
  CHECK(far.assign(7 * kSecond, at(502.0)).key == KeyframeKey{3, 0});
}

TEST_CASE("session keys: an odometry reset opens a session in the new frame, stitch keeps the session") {
  SessionKeys keys{SessionPolicy{}};
  CHECK(keys.assign(1 * kSecond, at(0.0)).key == KeyframeKey{0, 0});
  CHECK(keys.assign(2 * kSecond, at(10.0)).key == KeyframeKey{0, 1});
  // The filter saw the reset at 3 s and stitches later poses on with T_continuous_odom = at(10).
  keys.on_odometry_reset(3 * kSecond, at(10.0));
  const SessionKeys::Assigned after = keys.assign(3 * kSecond, at(10.0));  // the new frame's origin, stitched
  CHECK(after.key == KeyframeKey{1, 0});
  CHECK(after.T_odom_sensor.isApprox(at(0.0)));  // in the new session's own frame
  CHECK(keys.assign(4 * kSecond, at(12.0)).T_odom_sensor.isApprox(at(2.0)));

  SessionPolicy stitch;
  stitch.new_session_on_reset = false;
  SessionKeys old{stitch};
  old.assign(1 * kSecond, at(0.0));
  old.on_odometry_reset(3 * kSecond, at(10.0));
  const SessionKeys::Assigned s = old.assign(3 * kSecond, at(10.0));
  CHECK(s.key == KeyframeKey{0, 1});
  CHECK(s.T_odom_sensor.isApprox(at(10.0)));
}

TEST_CASE("session keys: a replay rerun on its map skips the stored keyframes and continues their session") {
  SessionKeys keys{SessionPolicy{}};
  keys.restore(stored({{{0, 0}, 10, 0.0}, {{0, 1}, 20, 2.0}, {{1, 0}, 30, 0.0}, {{1, 1}, 40, 2.0}}), true);
  CHECK(keys.assign(30, at(0.0), 1002).stored);  // the drive of session 1, replayed again
  CHECK(keys.assign(40, at(2.0), 1003).stored);
  const SessionKeys::Assigned next = keys.assign(50, at(4.0), 77);
  CHECK_FALSE(next.stored);
  CHECK(next.key == KeyframeKey{1, 2});
  CHECK(next.note.find("session 1 goes on from keyframe 1/1") != std::string::npos);
  CHECK(keys.skipped() == 2);
}

TEST_CASE("session keys: another drive with the map's scan times is a new session, never skipped or numbered into a stored one") {
  // The map: one drive, keyframes at 10, 20, 30 us. Another log with the same times: the same first pose (odometry
  // starts at the origin) but other scans, then other poses.
  const auto map = stored({{{0, 0}, 10, 0.0}, {{0, 1}, 20, 2.0}, {{0, 2}, 30, 4.0}});
  SessionKeys other{SessionPolicy{}};
  other.restore(map, true);
  const SessionKeys::Assigned first = other.assign(10, at(0.0), 555);  // same time and pose, another scan
  CHECK_FALSE(first.stored);
  CHECK(first.key == KeyframeKey{1, 0});
  CHECK(first.note.find("session 1 opened: another drive within the time of the map's drives") == 0);
  CHECK(other.assign(20, at(2.0), 1001).key == KeyframeKey{1, 1});  // even a keyframe that looks stored: its own drive
  CHECK(other.skipped() == 0);

  // The same scans but another pose (a log of the same hour from another vehicle's odometry): not the map's either.
  SessionKeys moved{SessionPolicy{}};
  moved.restore(map, true);
  CHECK(moved.assign(10, at(0.5), 1000).key == KeyframeKey{1, 0});

  // A stored session's later keyframe is never where a replay starts: the run's first keyframe must be a first one.
  SessionKeys late{SessionPolicy{}};
  late.restore(map, true);
  CHECK_FALSE(late.assign(20, at(2.0), 1001).stored);

  // Maps from before fingerprints (0): time and pose decide.
  auto old_map = map;
  for (StoredKeyframe& k : old_map) k.scan_fingerprint = 0;
  SessionKeys old{SessionPolicy{}};
  old.restore(old_map, true);
  CHECK(old.assign(10, at(0.0), 555).stored);
  CHECK(old.assign(20, at(2.0), 556).stored);
  CHECK(old.assign(30, at(9.0), 557).key == KeyframeKey{1, 0});  // diverged inside the stored drive: a session of its own
}

TEST_CASE("session keys: a replay that diverges from the stored drive before its end opens a new session") {
  SessionKeys keys{SessionPolicy{}};
  keys.restore(stored({{{0, 0}, 10, 0.0}, {{0, 1}, 20, 2.0}, {{0, 2}, 30, 4.0}}), true);
  CHECK(keys.assign(10, at(0.0), 1000).stored);
  const SessionKeys::Assigned diverged = keys.assign(25, at(3.0), 9);  // another keyframe config selects another scan
  CHECK(diverged.key == KeyframeKey{1, 0});
  CHECK(diverged.note.find("is not the map's next one") != std::string::npos);
}
