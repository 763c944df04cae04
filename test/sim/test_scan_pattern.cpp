// Non-repetitive solid-state patterns (Livox Avia-like rosette, MID-360-like): field of view, count, times, and no
// two scans alike; a drive of them through the simulator.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/scan_pattern.hpp"
#include "loopd/sim/town.hpp"

using namespace loopd;

namespace {
double azimuth_deg(const Eigen::Vector3d& d) { return std::atan2(d.y(), d.x()) * 180.0 / M_PI; }
double elevation_deg(const Eigen::Vector3d& d) { return std::asin(d.z()) * 180.0 / M_PI; }
}  // namespace

TEST_CASE("the rosette fills its cone: 24,000 rays inside 70.4 x 77.2 deg, times over one sweep, never repeated") {
  const LidarModel avia = lidar_model_avia();
  REQUIRE_FALSE(avia.validate().has_value());
  const std::vector<PatternRay> a = pattern_rays(avia, 0.1, 1), b = pattern_rays(avia, 0.1, 2);
  REQUIRE(a.size() == 24000);
  double az_lo = 1e9, az_hi = -1e9, el_lo = 1e9, el_hi = -1e9;
  for (const PatternRay& r : a) {
    CHECK(r.direction.norm() == Approx(1.0));
    az_lo = std::min(az_lo, azimuth_deg(r.direction));
    az_hi = std::max(az_hi, azimuth_deg(r.direction));
    el_lo = std::min(el_lo, elevation_deg(r.direction));
    el_hi = std::max(el_hi, elevation_deg(r.direction));
  }
  // The cone plus the lasers' 1.5 deg spacing on either side; the rosette reaches its rim.
  CHECK(az_hi - az_lo == Approx(70.4 + 7.5).margin(3.0));
  CHECK(el_lo == Approx(-38.6).margin(1.5));
  CHECK(el_hi == Approx(38.6).margin(1.5));
  CHECK(a.front().time == Approx(-0.1 + 0.1 / 4000).margin(1e-6));
  CHECK(a.back().time == 0.f);
  // Another scan traces another path.
  double moved = 0;
  for (std::size_t i = 0; i < a.size(); i += 100) moved += (a[i].direction - b[i].direction).norm();
  CHECK(moved / (a.size() / 100) > 0.05);
  // A spinning model has no pattern.
  CHECK(pattern_rays(lidar_model_vlp16(), 0.1, 1).empty());
}

TEST_CASE("the MID-360-like pattern turns once a scan over -7..+52 deg") {
  const LidarModel mid = lidar_model_mid360();
  REQUIRE_FALSE(mid.validate().has_value());
  const std::vector<PatternRay> rays = pattern_rays(mid, 0.1, 5);
  REQUIRE(rays.size() == 20000);
  std::vector<int> sectors(36, 0);
  for (const PatternRay& r : rays) {
    const double e = elevation_deg(r.direction);
    CHECK(e >= -7.0 - 1e-6);
    CHECK(e <= 52.0 + 1e-6);
    ++sectors[static_cast<std::size_t>(std::clamp(static_cast<int>((azimuth_deg(r.direction) + 180.0) / 10.0), 0, 35))];
  }
  for (const int n : sectors) CHECK(n > 300);  // every 10 deg of azimuth
}

TEST_CASE("a simulated Avia scan is narrow, without rings, and auto sees no ring pattern") {
  const Town town = make_town(7);
  const PointCloud scan = simulate_sweep(
      town, lidar_model_avia(), [&](double) { return street_pose(town, 1, 1, 0, 20.0); }, 0.1, SensorEffects::none(), 9, 2);
  REQUIRE(scan.size() > 10000);
  CHECK_FALSE(scan.has_rings());
  const SensorEstimate est = estimate_sensor(scan);
  REQUIRE(est.ok);
  CHECK_FALSE(est.rings_resolved);
  CHECK(est.azimuth_coverage_deg < 100.0);
  CHECK_FALSE(sensor_model_from_choice("avia").has_value());  // loopd reads such scans as auto
  CHECK_FALSE(validate_sensor_choice("mid360").has_value());
}
