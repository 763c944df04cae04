#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/base/deskew.hpp"
#include "loopd/runtime/scan_pose_associator.hpp"

using namespace loopd;

namespace {
StampedPose pose_at(std::int64_t utime, double x, double yaw, double residual = 0.0) {
  StampedPose p;
  p.utime = utime;
  p.T_world_sensor = make_isometry(x, 0, 0, yaw);
  p.residual = residual;
  return p;
}
PointCloud small_cloud() {
  PointCloud c;
  c.points = {{1, 2, 3}, {4, 5, 6}};
  return c;
}
}  // namespace

TEST_CASE("a scan at a pose's exact utime takes that pose") {
  ScanPoseAssociator a(AssociationConfig{});
  REQUIRE(a.add_pose(pose_at(1'000'000, 3.0, 0.2)));
  REQUIRE(a.add_scan(1'000'000, small_cloud(), 0.0));
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  CHECK(out[0].pose.T_world_sensor.translation().x() == Approx(3.0));
}

TEST_CASE("a scan between two poses is interpolated: linear translation, slerp rotation") {
  ScanPoseAssociator a(AssociationConfig{});
  a.add_pose(pose_at(1'000'000, 0.0, 0.0));
  a.add_pose(pose_at(1'100'000, 1.0, 0.4));
  a.add_scan(1'025'000, small_cloud(), 0.0);
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  const Eigen::Isometry3d& T = out[0].pose.T_world_sensor;
  CHECK(T.translation().x() == Approx(0.25).margin(1e-12));
  CHECK(rotation_angle(T) == Approx(0.1).margin(1e-12));
  CHECK(Eigen::AngleAxisd(T.linear()).axis().z() == Approx(1.0));
}

TEST_CASE("a scan waits for its later pose, then resolves") {
  ScanPoseAssociator a(AssociationConfig{});
  a.add_pose(pose_at(1'000'000, 0.0, 0.0));
  a.add_scan(1'050'000, small_cloud(), 0.0);
  CHECK(a.poll(0.0, false).empty());
  CHECK(a.pending() == 1);
  a.add_pose(pose_at(1'100'000, 2.0, 0.0));
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  CHECK(out[0].pose.T_world_sensor.translation().x() == Approx(1.0));
}

TEST_CASE("a scan with no pose is dropped after the hold time and counted") {
  AssociationConfig cfg;
  cfg.hold_time = 0.5;
  ScanPoseAssociator a(cfg);
  a.add_scan(5'000'000, small_cloud(), 10.0);
  CHECK(a.poll(10.2, true).empty());
  CHECK(a.dropped_no_pose() == 0);
  CHECK(a.poll(10.6, true).empty());  // wall clock passed the hold time
  CHECK(a.dropped_no_pose() == 1);
  CHECK(a.pending() == 0);
}

TEST_CASE("a scan whose bracketing poses are farther apart than the tolerance is dropped") {
  AssociationConfig cfg;
  cfg.tolerance = 0.1;
  ScanPoseAssociator a(cfg);
  a.add_pose(pose_at(1'000'000, 0.0, 0.0));
  a.add_scan(1'300'000, small_cloud(), 0.0);
  a.add_pose(pose_at(1'600'000, 1.0, 0.0));
  CHECK(a.poll(0.0, false).empty());
  CHECK(a.dropped_no_pose() == 1);
}

TEST_CASE("duplicate and out-of-order utimes are rejected and counted") {
  ScanPoseAssociator a(AssociationConfig{});
  CHECK(a.add_pose(pose_at(2'000'000, 0, 0)));
  CHECK_FALSE(a.add_pose(pose_at(2'000'000, 0, 0)));
  CHECK_FALSE(a.add_pose(pose_at(1'000'000, 0, 0)));
  CHECK(a.rejected_pose_order() == 2);
  CHECK(a.add_scan(2'000'000, small_cloud(), 0));
  CHECK_FALSE(a.add_scan(2'000'000, small_cloud(), 0));
  CHECK_FALSE(a.add_scan(1'500'000, small_cloud(), 0));
  CHECK(a.rejected_scan_order() == 2);
}

TEST_CASE("residuals of the poses between two scans are summed for the correction weights") {
  ScanPoseAssociator a(AssociationConfig{});
  a.add_pose(pose_at(1'000'000, 0, 0, 0.1));
  a.add_scan(1'000'000, small_cloud(), 0);
  auto first = a.poll(0, false);
  REQUIRE(first.size() == 1);
  a.add_pose(pose_at(1'050'000, 0.5, 0, 0.2));
  a.add_pose(pose_at(1'100'000, 1.0, 0, 0.3));
  a.add_scan(1'100'000, small_cloud(), 0);
  auto second = a.poll(0, false);
  REQUIRE(second.size() == 1);
  CHECK(second[0].residual_sum == Approx(0.5));
}

TEST_CASE("tolerance and hold_time are bounded so that they fit int64 microseconds (issue 19, -Wconversion survey)") {
  // Both are turned into int64 microseconds (static_cast<std::int64_t>(seconds * 1e6)). 1e13 s passed validate() before,
  // and 1e19 us does not fit an int64: the cast is undefined (x86 gives INT64_MIN, so every interpolated scan was
  // dropped). The limit is 1e6 s (about 11.6 days, 1e12 us).
  AssociationConfig cfg;
  REQUIRE_FALSE(cfg.validate());
  for (double seconds : {1e13, 1e300, HUGE_VAL}) {
    AssociationConfig t = cfg;
    t.tolerance = seconds;
    CHECK(t.validate());
    AssociationConfig h = cfg;
    h.hold_time = seconds;
    CHECK(h.validate());
  }
  // At the limit a scan between two poses 1000 s apart is still interpolated (the int64 tolerance is 1e12 us).
  AssociationConfig wide = cfg;
  wide.tolerance = 1e6;
  wide.hold_time = 1e6;
  REQUIRE_FALSE(wide.validate());
  ScanPoseAssociator a(wide);
  REQUIRE(a.add_pose(pose_at(1'000'000, 0.0, 0.0)));
  REQUIRE(a.add_pose(pose_at(1'001'000'000, 10.0, 0.0)));
  REQUIRE(a.add_scan(501'000'000, small_cloud(), 0.0));
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  CHECK(out[0].pose.T_world_sensor.translation().x() == Approx(5.0));
}

namespace {
/// A cloud whose per-point times run from `from` to `to` [s] (relative to the scan's utime).
PointCloud timed_cloud(float from, float to) {
  PointCloud c = small_cloud();
  c.time = {from, to};
  return c;
}
}  // namespace

TEST_CASE("with sweep poses, a scan stamped at its sweep's start waits for a pose after its last point") {
  ScanPoseAssociator a(AssociationConfig{}, true);
  for (std::int64_t u = 0; u <= 1'000'000; u += 100'000) a.add_pose(pose_at(u, 0.1 * static_cast<double>(u / 100'000), 0.0));
  a.add_scan(1'000'000, timed_cloud(0.0f, 0.099f), 0.0);  // 1.000 .. 1.099 s: the pose at 1.1 s closes the sweep
  CHECK(a.poll(0.0, false).empty());
  a.add_pose(pose_at(1'100'000, 1.1, 0.0));
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  // Two poses before the sweep (0.8, 0.9 s), the one in it (1.0 s) and the one closing it (1.1 s; none after it yet).
  REQUIRE(out[0].sweep_poses.size() == 4);
  CHECK(out[0].sweep_poses.front().utime == 800'000);
  CHECK(out[0].sweep_poses.back().utime == 1'100'000);
}

TEST_CASE("with sweep poses, a scan stamped at its sweep's end leaves with its own pose and those before it") {
  ScanPoseAssociator a(AssociationConfig{}, true);
  for (std::int64_t u = 0; u <= 1'000'000; u += 100'000) a.add_pose(pose_at(u, 0.0, 0.0));
  a.add_scan(1'000'000, timed_cloud(-0.1f, 0.0f), 0.0);
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);  // no extra wait: its last point is at its stamp
  REQUIRE(out[0].sweep_poses.size() == 4);
  CHECK(out[0].sweep_poses.front().utime == 700'000);  // two before the sweep's start at 0.9 s
  CHECK(out[0].sweep_poses.back().utime == 1'000'000);
}

TEST_CASE("with sweep poses, the first scan, whose sweep begins before the first pose, waits for a second pose") {
  // A drive's first scan stamped at its sweep's end: its points lie before the first pose, so deskew extrapolates
  // backwards at the first pose pair's velocity. Before this wait it left with one pose and was never deskewed: on
  // the skewed town drive (HDL-32E, seed 3) all 3 wrong loops of 536 closed on that keyframe.
  ScanPoseAssociator a(AssociationConfig{}, true);
  a.add_pose(pose_at(1'000'000, 0.0, 0.0));
  a.add_scan(1'000'000, timed_cloud(-0.1f, 0.0f), 0.0);
  CHECK(a.poll(0.0, false).empty());
  a.add_pose(pose_at(1'100'000, 1.0, 0.0));
  auto out = a.poll(0.0, false);
  REQUIRE(out.size() == 1);
  CHECK(out[0].pose.T_world_sensor.translation().x() == Approx(0.0));
  REQUIRE(out[0].sweep_poses.size() == 2);
  CHECK(out[0].sweep_poses.back().utime == 1'100'000);
  // With the pair, the sweep 0.9 .. 1.0 s is covered by extrapolation (0.1 s at 10 m/s, within max_extrapolation).
  PointCloud cloud = timed_cloud(-0.1f, 0.0f);
  const DeskewResult r = deskew(DeskewConfig{}, out[0].sweep_poses, 1'000'000, &cloud);
  CHECK(r.applied());
  CHECK(r.extrapolated == Approx(0.1).margin(1e-6));
}

TEST_CASE("with sweep poses, a scan waits at most hold_time for the rest of its sweep") {
  AssociationConfig cfg;
  cfg.hold_time = 0.3;
  SECTION("data time: later scans arrive while the odometry has stopped") {
    ScanPoseAssociator a(cfg, true);
    a.add_pose(pose_at(900'000, 0.0, 0.0));
    a.add_pose(pose_at(1'000'000, 0.1, 0.0));
    a.add_scan(1'000'000, timed_cloud(0.0f, 0.1f), 0.0);
    CHECK(a.poll(0.0, false).empty());
    a.add_scan(1'200'000, timed_cloud(0.0f, 0.1f), 0.0);
    CHECK(a.poll(0.0, false).empty());
    a.add_scan(1'400'000, timed_cloud(0.0f, 0.1f), 0.0);  // 0.4 s of data after the first scan
    auto out = a.poll(0.0, false);
    REQUIRE(out.size() == 1);  // it leaves with what there is (deskew extrapolates or skips); the others have no pose
    CHECK(out[0].utime == 1'000'000);
    CHECK(out[0].sweep_poses.size() == 2);
  }
  SECTION("live: the wall clock") {
    ScanPoseAssociator a(cfg, true);
    a.add_pose(pose_at(1'000'000, 0.1, 0.0));
    a.add_scan(1'000'000, timed_cloud(0.0f, 0.1f), 10.0);
    CHECK(a.poll(10.2, true).empty());
    CHECK(a.poll(10.4, true).size() == 1);
  }
  SECTION("at the end of input") {
    ScanPoseAssociator a(cfg, true);
    a.add_pose(pose_at(1'000'000, 0.1, 0.0));
    a.add_scan(1'000'000, timed_cloud(0.0f, 0.1f), 0.0);
    CHECK(a.flush().size() == 1);
  }
}

TEST_CASE("without sweep poses, or without times, scans resolve as before and carry no sweep poses") {
  ScanPoseAssociator off(AssociationConfig{});
  ScanPoseAssociator on(AssociationConfig{}, true);
  for (auto* a : {&off, &on}) {
    a->add_pose(pose_at(1'000'000, 0.0, 0.0));
    a->add_pose(pose_at(1'100'000, 1.0, 0.0));
  }
  off.add_scan(1'050'000, timed_cloud(0.0f, 0.1f), 0.0);  // would wait for 1.15 s with sweep poses
  on.add_scan(1'050'000, small_cloud(), 0.0);
  for (auto* a : {&off, &on}) {
    auto out = a->poll(0.0, false);
    REQUIRE(out.size() == 1);
    CHECK(out[0].sweep_poses.empty());
    CHECK(out[0].pose.T_world_sensor.translation().x() == Approx(0.5));
  }
}
