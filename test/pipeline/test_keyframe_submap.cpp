// Keyframe submaps of a narrow or sparse sensor: which scans need one, which earlier scans join, and where their points
// land in the keyframe's frame.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/pipeline/keyframe_submap.hpp"

using namespace loopd;

namespace {

/// A scan of `n` points spread over `fov_deg` of azimuth ahead, 10 m away.
PointCloud fan(int n, double fov_deg) {
  PointCloud c;
  for (int i = 0; i < n; ++i) {
    const double a = (-0.5 + (i + 0.5) / n) * fov_deg * M_PI / 180.0;
    c.points.emplace_back(static_cast<float>(10.0 * std::cos(a)), static_cast<float>(10.0 * std::sin(a)), static_cast<float>(0.01 * (i % 50)));
  }
  return c;
}

std::shared_ptr<const WindowScan> kept(std::int64_t utime, double x, PointCloud cloud = {}) {
  auto s = std::make_shared<WindowScan>();
  s->utime = utime;
  s->T_odom_sensor.translation() = Eigen::Vector3d(x, 0, 0);
  s->cloud = std::move(cloud);
  return s;
}

}  // namespace

TEST_CASE("narrow or sparse scans need a submap, a full spinning scan does not") {
  const KeyframeSubmapConfig c;
  CHECK(needs_submap(fan(20000, 70.0), c));  // a 70 deg cone
  CHECK(needs_submap(fan(3000, 360.0), c));  // all round but sparse
  CHECK_FALSE(needs_submap(fan(20000, 360.0), c));
  CHECK(needs_submap(PointCloud(), c));
  KeyframeSubmapConfig off = c;
  off.enabled = false;
  CHECK_FALSE(needs_submap(fan(20000, 70.0), off));
}

TEST_CASE("the mode switches only after `confirm` scans agree") {
  KeyframeSubmapConfig c;
  c.confirm = 3;
  ScanWindow w(c);
  CHECK_FALSE(w.update_mode(true));
  CHECK_FALSE(w.update_mode(true));
  CHECK(w.update_mode(true));
  CHECK(w.update_mode(false));  // one odd scan changes nothing
  CHECK(w.update_mode(true));
  w.push(kept(1, 0.0));
  CHECK_FALSE((w.update_mode(false), w.update_mode(false), w.update_mode(false)));
  CHECK(w.size() == 0);  // leaving submap mode lets the kept scans go
}

TEST_CASE("earlier scans within the window and the travel join, oldest first, at most max_scans") {
  KeyframeSubmapConfig c;
  c.window = 0.5;
  c.max_travel = 5.0;
  c.max_scans = 3;
  ScanWindow w(c);
  for (int i = 0; i < 8; ++i) w.push(kept(1'000'000 + i * 100'000, i * 1.0));  // 10 Hz, 1 m a scan
  const Eigen::Isometry3d T_keyframe(Eigen::Translation3d(7.0, 0, 0));
  auto r = w.recent(1'700'000, T_keyframe);  // the keyframe is the newest scan: itself is not merged
  REQUIRE(r.size() == 3);
  CHECK(r[0]->utime == 1'400'000);
  CHECK(r[2]->utime == 1'600'000);
  c.max_scans = 10;
  c.max_travel = 2.5;
  ScanWindow near(c);
  for (int i = 0; i < 8; ++i) near.push(kept(1'000'000 + i * 100'000, i * 1.0));
  CHECK(near.recent(1'700'000, T_keyframe).size() == 2);  // 1 m and 2 m back; 3 m is beyond the travel
}

TEST_CASE("merged points land in the keyframe's frame, times and rings are dropped") {
  PointCloud key;
  key.points = {Eigen::Vector3f(1, 0, 0)};
  key.time = {0.f};
  key.ring = {3};
  key.num_rings = 16;
  PointCloud earlier;
  earlier.points = {Eigen::Vector3f(5, 1, 0), Eigen::Vector3f(std::nanf(""), 0, 0)};
  // The earlier scan was taken 2 m behind the keyframe and turned 90 deg left.
  auto s = std::make_shared<WindowScan>();
  s->utime = 1;
  s->cloud = earlier;
  s->T_odom_sensor = Eigen::Translation3d(-2, 0, 0) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  DeskewConfig d;
  const int merged = merge_submap({s}, Eigen::Isometry3d::Identity(), d, &key);
  CHECK(merged == 1);
  REQUIRE(key.size() == 2);  // the NaN point is not merged
  CHECK((key.points[1] - Eigen::Vector3f(-2 - 1, 5, 0)).norm() < 1e-5);
  CHECK(key.time.empty());
  CHECK_FALSE(key.has_rings());
}
