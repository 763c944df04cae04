// Multi-session drives: session 1 is the drive of before sessions; session K >= 2 drives the same town from another
// start (reversed for even K) in its own odometry frame, noise and time; an odometry reset restarts the odometry; the
// ring route drifts far before its first revisit.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>

#include "loopd/sim/drive.hpp"

namespace {
constexpr double kPi = 3.14159265358979323846;

double yaw_of(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }
double angle_diff(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * kPi)); }

std::uint64_t fnv(std::uint64_t h, const void* p, std::size_t n) {
  const auto* b = static_cast<const unsigned char*>(p);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
  return h;
}
/// FNV-1a over every scan's utime, ground truth, odometry, residual, visit and route distance.
std::uint64_t pose_hash(const loopd::Drive& d) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const auto& s : d.scans) {
    h = fnv(h, &s.utime, 8), h = fnv(h, s.T_world_sensor.data(), 128), h = fnv(h, s.odometry.T_world_sensor.data(), 128);
    h = fnv(h, &s.odometry.residual, 8), h = fnv(h, &s.visit, 4), h = fnv(h, &s.route_distance, 8);
  }
  return h;
}
/// Distance from p to the nearest sample of session 1's lap path.
double distance_to_path(const loopd::Drive& d1, const Eigen::Vector3d& p) {
  double best = 1e300;
  for (const auto& q : d1.path) best = std::min(best, (q.p - p.head<2>()).squaredNorm());
  return std::sqrt(best);
}
loopd::DriveConfig small(const std::string& route, int scans, int session) {
  loopd::DriveConfig c;
  c.sensor = "vlp16";
  c.route = route;
  c.num_scans = scans;
  c.seed = 3;
  c.session = session;
  return c;
}
}  // namespace

TEST_CASE("session 1 is the drive of before sessions, bit for bit", "[sim][drive][session]") {
  // Hashes of the drives make_drive built before sessions existed (commit 038b817), taken again when the heading came
  // to be interpolated between route samples (it stepped at each before).
  loopd::DriveConfig town;
  town.num_scans = 1500;
  CHECK(pose_hash(loopd::make_drive(town)) == 0x66942e3b5397518bull);
  loopd::DriveConfig block = small("block", 1500, 1);
  CHECK(pose_hash(loopd::make_drive(block)) == 0x9ad0ab65b8c3a2c4ull);
  const auto d = loopd::make_drive(block);
  CHECK(d.start_offset == 0.0);
  CHECK_FALSE(d.reversed);
  CHECK(d.car_visit_offset == 0);
  CHECK(d.scans.front().odometry.T_world_sensor.matrix() == d.scans.front().T_world_sensor.matrix());
}

TEST_CASE("session K >= 2 drives the same town from elsewhere, in its own odometry frame and day", "[sim][drive][session]") {
  for (const char* route : {"town", "block", "ring"}) {
    const auto d1 = loopd::make_drive(small(route, 300, 1));
    for (int k = 2; k <= 5; ++k) {
      CAPTURE(route, k);
      const auto dk = loopd::make_drive(small(route, 300, k));
      REQUIRE(dk.error.empty());
      // The same static town.
      REQUIRE(dk.town.primitives.size() == d1.town.primitives.size());
      for (std::size_t q = 0; q < d1.town.primitives.size(); ++q) {
        const auto &a = d1.town.primitives[q], &b = dk.town.primitives[q];
        if (a.movable_id >= 0) continue;
        REQUIRE((a.a == b.a && a.b == b.b && a.radius == b.radius && a.type == b.type));
      }
      CHECK(dk.reversed == (k % 2 == 0));
      CHECK(dk.car_visit_offset == (k - 1) << 20);
      // Starts elsewhere.
      const auto &s1 = d1.scans.front(), &sk = dk.scans.front();
      const double apart = (s1.T_world_sensor.translation() - sk.T_world_sensor.translation()).norm();
      CHECK((apart > 50.0 || angle_diff(yaw_of(s1.T_world_sensor), yaw_of(sk.T_world_sensor)) > 0.5 * kPi));
      // Own odometry frame from identity, ground truth in session 1's world frame, a day later per session.
      CHECK(sk.odometry.T_world_sensor.isApprox(Eigen::Isometry3d::Identity(), 0.0));
      CHECK(sk.utime == s1.utime + std::int64_t{86400000000} * (k - 1));
      CHECK(dk.scans.back().utime - sk.utime == d1.scans.back().utime - s1.utime);
      // On session 1's lap path: the same lane forward, the opposite lane (4 m over, within a lane width) reversed.
      for (std::size_t i = 0; i < dk.scans.size(); i += 10) {
        const double off = distance_to_path(d1, dk.scans[i].T_world_sensor.translation());
        if (dk.reversed) {
          REQUIRE(off < 4.3);
        } else {
          REQUIRE(off < 0.1);
        }
      }
    }
  }
}

TEST_CASE("a reversed session drives the route the other way, sessions draw their own noise", "[sim][drive][session]") {
  const auto d1 = loopd::make_drive(small("block", 800, 1));
  const auto d2 = loopd::make_drive(small("block", 400, 2));
  const auto d3 = loopd::make_drive(small("block", 400, 3));
  // Along the same street, session 1 heads the other way wherever session 2 passes it in the opposite lane.
  int opposite = 0, compared = 0;
  for (std::size_t i = 0; i < d2.scans.size(); i += 5) {
    const Eigen::Vector3d p = d2.scans[i].T_world_sensor.translation();
    std::size_t bj = 0;
    double best = 1e300;
    for (std::size_t j = 0; j < d1.scans.size(); ++j) {
      const double dist = (d1.scans[j].T_world_sensor.translation() - p).norm();
      if (dist < best) best = dist, bj = j;
    }
    if (best > 6.0) continue;
    ++compared;
    if (angle_diff(yaw_of(d1.scans[bj].T_world_sensor), yaw_of(d2.scans[i].T_world_sensor)) > kPi - 0.3) ++opposite;
  }
  REQUIRE(compared > 50);
  CHECK(opposite > 0.8 * compared);
  // Sessions 2 and 3: own odometry steps and scan seeds.
  auto step_error = [](const loopd::Drive& d, std::size_t i) {
    const Eigen::Isometry3d o = d.scans[i - 1].odometry.T_world_sensor.inverse() * d.scans[i].odometry.T_world_sensor;
    const Eigen::Isometry3d g = d.scans[i - 1].T_world_sensor.inverse() * d.scans[i].T_world_sensor;
    return Eigen::Vector3d(o.translation() - g.translation());
  };
  int differ = 0;
  for (std::size_t i = 1; i < 100; ++i) differ += (step_error(d2, i) - step_error(d3, i)).norm() > 1e-6 ? 1 : 0;
  CHECK(differ > 90);
  CHECK(d2.scan_seed(7) != d3.scan_seed(7));
  CHECK(d1.scan_seed(7) != d3.scan_seed(7));
  CHECK(d2.scans[5].odometry.residual != d3.scans[5].odometry.residual);
}

TEST_CASE("an odometry reset restarts the odometry at identity, ground truth runs on", "[sim][drive][session]") {
  for (int k : {1, 2}) {
    CAPTURE(k);
    auto cfg = small("town", 200, k);
    const auto plain = loopd::make_drive(cfg);
    cfg.odometry_reset_at = 120;
    const auto d = loopd::make_drive(cfg);
    REQUIRE(d.error.empty());
    CHECK(d.scans[120].odometry.T_world_sensor.isApprox(Eigen::Isometry3d::Identity(), 0.0));
    CHECK(d.scans[119].odometry_segment == 0);
    CHECK(d.scans[120].odometry_segment == 1);
    for (std::size_t i = 0; i < d.scans.size(); ++i) {
      REQUIRE(d.scans[i].T_world_sensor.matrix() == plain.scans[i].T_world_sensor.matrix());
      if (i < 120) REQUIRE(d.scans[i].odometry.T_world_sensor.matrix() == plain.scans[i].odometry.T_world_sensor.matrix());
    }
    // Ground truth continuous across the reset (1 m steps), odometry steps after it as without the reset.
    CHECK((d.scans[120].T_world_sensor.translation() - d.scans[119].T_world_sensor.translation()).norm() == Approx(1.0).margin(0.05));
    const Eigen::Isometry3d after = d.scans[120].odometry.T_world_sensor.inverse() * d.scans[150].odometry.T_world_sensor;
    const Eigen::Isometry3d plain_after = plain.scans[120].odometry.T_world_sensor.inverse() * plain.scans[150].odometry.T_world_sensor;
    CHECK(after.isApprox(plain_after, 1e-9));
  }
}

TEST_CASE("bad sessions and odometry resets are rejected with a clear error", "[sim][drive][session]") {
  for (int k : {0, -1, 1001}) {
    auto cfg = small("block", 50, k);
    CAPTURE(k);
    REQUIRE(cfg.validate());
    CHECK(cfg.validate()->find("session must be in [1, 1000]") != std::string::npos);
    CHECK_FALSE(loopd::make_drive(cfg).error.empty());
  }
  for (int n : {0, -5, 50, 51}) {
    auto cfg = small("block", 50, 1);
    cfg.odometry_reset_at = n;
    CAPTURE(n);
    REQUIRE(cfg.validate());
    CHECK(cfg.validate()->find("must be in [1, num_scans = 50)") != std::string::npos);
  }
  auto ok = small("block", 50, 1000);
  ok.odometry_reset_at = 49;
  CHECK_FALSE(ok.validate());
}

TEST_CASE("the ring route with 3 deg/100 m and 3 % drift is first revisited after a round, drifted past the gate's 40 m", "[sim][drive][ring]") {
  auto cfg = small("ring", 1700, 1);
  cfg.heading_bias_deg_per_100m = 3.0;
  cfg.scale_bias = 0.03;
  const auto d = loopd::make_drive(cfg);
  REQUIRE(d.error.empty());
  int first = -1;
  for (std::size_t i = 100; i < d.scans.size() && first < 0; ++i)
    for (std::size_t j = 0; j + 100 <= i; ++j)
      if ((d.scans[i].T_world_sensor.translation() - d.scans[j].T_world_sensor.translation()).norm() < 2.0) {
        first = static_cast<int>(i);
        break;
      }
  REQUIRE(first > 0);
  const auto& s = d.scans[static_cast<std::size_t>(first)];
  const double drift = (s.odometry.T_world_sensor.translation() - s.T_world_sensor.translation()).norm();
  WARN("ring: lap " << d.lap_length << " m (3 rounds), first revisit at " << s.route_distance << " m, odometry drift " << drift << " m");
  CHECK(s.route_distance > 1000.0);
  CHECK(drift > 40.0);
}
