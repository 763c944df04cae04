// Which session a keyframe belongs to (SessionKeys): a drive on a map continues its newest session only when its
// odometry plainly goes on from it; another drive, or an odometry reset, opens a new session.
#include <catch2/catch.hpp>

#include "session_keys.hpp"

using namespace loopd;

namespace {
Eigen::Isometry3d at(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}
constexpr std::int64_t kSecond = 1000000;
}  // namespace

TEST_CASE("session keys: a new map starts session 0; a drive that goes on from the map's newest keyframe continues it") {
  SessionKeys fresh{SessionPolicy{}};
  const SessionKeys::Assigned a = fresh.assign(5 * kSecond, at(0.0));
  CHECK(a.key == KeyframeKey{0, 0});
  CHECK(fresh.assign(6 * kSecond, at(2.0)).key == KeyframeKey{0, 1});

  SessionKeys restarted{SessionPolicy{}};  // loopd restarted 3 s later, 20 m on (a car at 25 km/h)
  restarted.restore({{0, 0}, {0, 1}}, {5 * kSecond, 6 * kSecond}, at(2.0), false);
  const SessionKeys::Assigned b = restarted.assign(9 * kSecond, at(22.0));
  CHECK(b.key == KeyframeKey{0, 2});
  CHECK(b.note.find("continuing session 0") == 0);
}

TEST_CASE("session keys: another day's drive, or one that starts far from the map's end, opens a new session") {
  SessionKeys next_day{SessionPolicy{}};
  next_day.restore({{0, 0}, {0, 1}}, {5 * kSecond, 6 * kSecond}, at(2.0), false);
  const SessionKeys::Assigned a = next_day.assign(6 * kSecond + 86400 * kSecond, at(0.0));
  CHECK(a.key == KeyframeKey{1, 0});
  CHECK(a.note.find("session 1 opened") == 0);
  CHECK(next_day.assign(6 * kSecond + 86401 * kSecond, at(2.0)).key == KeyframeKey{1, 1});

  SessionKeys far{SessionPolicy{}};  // 1 s later but 500 m away: not the same odometry
  far.restore({{0, 0}, {2, 7}}, {5 * kSecond, 6 * kSecond}, at(2.0), false);
  CHECK(far.assign(7 * kSecond, at(502.0)).key == KeyframeKey{3, 0});
}

TEST_CASE("session keys: an odometry reset opens a session in the new frame; stitch keeps the session") {
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
  keys.restore({{0, 0}, {0, 1}, {1, 0}, {1, 1}}, {10, 20, 30, 40}, at(5.0), true);
  CHECK(keys.assign(30, at(0.0)).stored);  // the drive of session 1, replayed again
  CHECK(keys.assign(40, at(2.0)).stored);
  const SessionKeys::Assigned next = keys.assign(50, at(4.0));
  CHECK_FALSE(next.stored);
  CHECK(next.key == KeyframeKey{1, 2});
  CHECK(keys.skipped() == 2);
}
