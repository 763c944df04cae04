#include <catch2/catch.hpp>
#include <cmath>

#include "scan_pose_associator.hpp"

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
