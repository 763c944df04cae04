// LocalizationTracker (loopd --localize): one state per keyframe once its decisions and their correction are in; it
// becomes localized at the correction that anchors this run's session, counts only accepted loops to other sessions,
// and takes the keyframe's corrected pose from that correction.
#include <catch2/catch.hpp>

#include "loopd/runtime/localization_tracker.hpp"

using namespace loopd;

namespace {

KeyframeRecord keyframe(std::int64_t index, const Eigen::Isometry3d& T_odom_sensor) {
  KeyframeRecord k;
  k.key = KeyframeKey{1, index};
  k.utime = 1000000 + 100000 * index;
  k.T_odom_sensor = T_odom_sensor;
  return k;
}

LoopDecision loop(const KeyframeKey& query, const KeyframeKey& match, bool accepted, std::int64_t utime) {
  LoopDecision d;
  d.query = query;
  d.match = match;
  d.query_utime = utime;
  d.status = accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
  return d;
}

Eigen::Isometry3d at(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

}  // namespace

TEST_CASE("localization tracker: localized at the correction that anchors the run, with the corrected pose and its loops") {
  LocalizationTracker tracker;
  // Keyframe 0: placed in its own frame (stitched on where the map's last keyframe lay), no loop: not localized.
  const KeyframeRecord k0 = keyframe(0, at(5.0, 0.0, 0.0));
  tracker.on_keyframe(k0, at(105.0, 3.0, 0.0));
  tracker.on_decision(loop(k0.key, {0, 4}, false, k0.utime));   // rejected: not counted
  CHECK_FALSE(tracker.on_keyframe_decided(KeyframeKey{1, 7}));  // not the newest keyframe
  const std::optional<LocalizationState> s0 = tracker.on_keyframe_decided(k0.key);
  REQUIRE(s0);
  CHECK_FALSE(s0->localized);
  CHECK(s0->localized_since_utime == 0);
  CHECK(s0->loops_to_map == 0);
  CHECK(s0->T_map_odom.isApprox(at(100.0, 3.0, 0.0)));
  CHECK_FALSE(tracker.on_keyframe_decided(k0.key));  // once

  // Keyframe 1: a loop to the map's session 0 and one within the run; the correction anchors session 1.
  const KeyframeRecord k1 = keyframe(1, at(6.0, 0.0, 0.1));
  tracker.on_keyframe(k1, at(106.0, 3.0, 0.1));
  tracker.on_decision(loop(k1.key, {0, 4}, true, k1.utime));
  tracker.on_decision(loop(k1.key, {1, 0}, true, k1.utime));  // within the run: not a loop to the map
  CorrectionOutput c;
  c.keys = {KeyframeKey{0, 4}, k0.key, k1.key};
  c.T_map_sensor = {at(0.0, 0.0, 0.0), at(20.0, 1.0, 0.3), at(21.0, 1.5, 0.4)};
  c.sessions = {SessionAlignment{0, true, Eigen::Isometry3d::Identity(), 5}, SessionAlignment{1, true, at(15.0, 1.0, 0.3), 2}};
  tracker.on_correction(c);
  const std::optional<LocalizationState> s1 = tracker.on_keyframe_decided(k1.key);
  REQUIRE(s1);
  CHECK(s1->localized);
  CHECK(s1->localized_since_utime == k1.utime);
  CHECK(s1->loops_to_map == 1);
  CHECK(s1->last_loop_utime == k1.utime);
  CHECK(s1->T_map_sensor.isApprox(at(21.0, 1.5, 0.4)));                   // the corrected pose
  CHECK((s1->T_map_odom * k1.T_odom_sensor).isApprox(s1->T_map_sensor));  // T_map_odom maps the odometry pose there

  // Keyframe 2: no loop; still localized since keyframe 1.
  const KeyframeRecord k2 = keyframe(2, at(7.0, 0.0, 0.1));
  tracker.on_keyframe(k2, at(22.0, 1.6, 0.4));
  const std::optional<LocalizationState> s2 = tracker.on_keyframe_decided(k2.key);
  REQUIRE(s2);
  CHECK(s2->localized);
  CHECK(s2->localized_since_utime == k1.utime);
  CHECK(s2->loops_to_map == 1);
}
