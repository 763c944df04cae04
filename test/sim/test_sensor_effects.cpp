// Simulator sensor effects (issue 17): motion skew over the sweep, per-point times, beam dropouts, vegetation that
// differs between visits; with every effect off the scans are the instantaneous scans of simulate_scan, bit for bit.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

#include "loopd/base/kdtree.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/sim/drive.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

loopd::Primitive box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  loopd::Primitive p;
  p.type = loopd::PrimitiveType::kBox;
  p.a = lo;
  p.b = hi;
  p.reflectivity = 0.5f;
  return p;
}

/// A hand-built scene: flat ground at z = 0 and the given primitives.
loopd::Town scene(std::vector<loopd::Primitive> primitives) {
  loopd::Town t;
  t.name = "test-scene";
  t.lane_markings = false;
  t.primitives = std::move(primitives);
  t.build_index();
  return t;
}

/// A VLP-16 without range noise or dropouts of its own, and with a far range limit (its weak-return dropouts grow
/// with range / max_range): what remains comes from the effects.
loopd::LidarModel clean_vlp16() {
  loopd::LidarModel m = loopd::lidar_model_vlp16();
  m.range_noise_sigma = 0.0;
  m.dropout_rate = 0.0;
  m.max_range = 1000.0;
  return m;
}

/// Column of a point given as range times the beam direction (what the simulator writes, skewed or not).
int column_of(const Eigen::Vector3f& p, int columns) {
  double az = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x()));
  if (az < 0.0) az += 2.0 * kPi;
  return static_cast<int>(std::lround(az / (2.0 * kPi) * columns)) % columns;
}

using RayKey = std::pair<int, int>;  // (column, ring)
std::map<RayKey, Eigen::Vector3f> by_ray(const loopd::PointCloud& c, int columns) {
  std::map<RayKey, Eigen::Vector3f> m;
  for (std::size_t i = 0; i < c.size(); ++i) m[{column_of(c.points[i], columns), c.ring[i]}] = c.points[i];
  return m;
}

bool identical(const loopd::PointCloud& a, const loopd::PointCloud& b) {
  return a.size() == b.size() && std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Eigen::Vector3f)) == 0 &&
         a.intensity == b.intensity && a.ring == b.ring && a.time == b.time && a.num_rings == b.num_rings;
}

loopd::SensorEffects only_skew() {
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.motion_skew = fx.point_times = true;
  return fx;
}

}  // namespace

TEST_CASE("motion skew: a moving sweep lies off the surfaces by speed x |time offset|, on them at the stamp", "[sim][effects][skew]") {
  // Walls across the direction of travel 15 m ahead and behind; the sensor drives +x at 10 m/s, at x = 0 at the stamp.
  const loopd::Town town = scene({box({15.0, -40.0, -1.0}, {16.0, 40.0, 12.0}), box({-16.0, -40.0, -1.0}, {-15.0, 40.0, 12.0})});
  const loopd::LidarModel model = clean_vlp16();
  const double speed = 10.0, period = 0.1;
  const loopd::SensorPoseAt pose_at = [&](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(speed * t, 0.0, 1.8);
    return T;
  };
  const loopd::PointCloud moving = loopd::simulate_sweep(town, model, pose_at, period, only_skew(), 3, 2);
  const loopd::PointCloud still = loopd::simulate_scan(town, model, pose_at(0.0), 3, 2);
  REQUIRE(moving.has_time());
  CHECK_FALSE(still.has_time());

  // A point read in the sensor frame at the stamp (x = 0) lies |x| - 15 m off its wall; measured t before the stamp,
  // from speed * |t| further back, it lies speed * |t| beyond the wall ahead or short of the wall behind.
  int wall = 0, early = 0, late = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    const Eigen::Vector3f& p = moving.points[i];
    if (p.z() < -1.7f) continue;            // the ground: skew moves its points along it
    if (std::abs(p.y()) > 30.0f) continue;  // the walls' ends (their faces along x)
    ++wall;
    const double off = std::abs(std::abs(static_cast<double>(p.x())) - 15.0);
    const double expected = speed * std::abs(static_cast<double>(moving.time[i]));
    worst = std::max(worst, std::abs(off - expected));
    if (moving.time[i] < -0.095f) early += off > 0.94 ? 1 : 0;
    if (moving.time[i] > -0.001f) late += off < 0.011 ? 1 : 0;
  }
  CAPTURE(wall, early, late);
  CHECK(wall > 3000);
  CHECK(worst < 2e-3);  // [m] float rounding
  CHECK(early > 50);    // the first columns, behind: ~1 m = speed x period
  CHECK(late > 5);      // the last columns, behind too: on the wall
  for (std::size_t i = 0; i < still.size(); ++i) {
    if (still.points[i].z() > -1.7f && std::abs(still.points[i].y()) < 30.0f) REQUIRE(std::abs(std::abs(still.points[i].x()) - 15.0f) < 2e-3f);
  }
}

TEST_CASE("time_offset spans one sweep period, follows the azimuth, and the ground truth is the pose at the stamp", "[sim][effects][skew]") {
  loopd::DriveConfig cfg;
  cfg.sensor = "vlp16";
  cfg.route = "block";
  cfg.num_scans = 40;
  cfg.seed = 11;
  const loopd::Drive drive = loopd::make_drive(cfg);
  REQUIRE(drive.error.empty());
  const int cols = drive.model.azimuth_steps;
  const double period = 1.0 / cfg.rate_hz;

  // Clockwise from behind: behind (first), left, ahead, right, behind (last, at the stamp).
  CHECK(loopd::column_time_offset(cols / 2, cols, period) == Approx(-period * (cols - 1) / cols));
  CHECK(loopd::column_time_offset(cols / 4, cols, period) == Approx(-0.75 * period).margin(period / cols));
  CHECK(loopd::column_time_offset(0, cols, period) == Approx(-0.5 * period).margin(period / cols));
  CHECK(loopd::column_time_offset(3 * cols / 4, cols, period) == Approx(-0.25 * period).margin(period / cols));
  CHECK(loopd::column_time_offset(cols / 2 + 1, cols, period) == 0.0);

  for (int i : {0, 25}) {
    const loopd::PointCloud scan = drive.simulate(i, 2);
    REQUIRE(scan.has_time());
    float lo = 0.0f, hi = -1.0f;
    for (std::size_t k = 0; k < scan.size(); ++k) {
      lo = std::min(lo, scan.time[k]);
      hi = std::max(hi, scan.time[k]);
      // Points are range times the beam direction: the azimuth gives the column and so the time.
      REQUIRE(scan.time[k] == static_cast<float>(loopd::column_time_offset(column_of(scan.points[k], cols), cols, period)));
    }
    CHECK(hi == 0.0f);
    CHECK(hi - lo == Approx(period * (cols - 1) / cols));
    // Ground truth: the true pose at the stamp, which the route gives for the scan's distance.
    const auto& s = drive.scans[static_cast<std::size_t>(i)];
    CHECK(drive.pose_at_distance(s.route_distance).matrix() == s.T_world_sensor.matrix());
  }

  // Against the instantaneous scan at the stamp's pose (same seed, so the same noise per ray): the last column
  // fired at the stamp is the same; the first, 0.1 s earlier, 1 m back on the route, differs where a surface is not
  // parallel to the motion (the ground and facades along the road give the same ranges from 1 m back).
  loopd::Drive skew_only = drive;
  skew_only.config.effects = only_skew();
  const auto& s = drive.scans[25];
  const auto moving = by_ray(skew_only.simulate(25, 2), cols);
  const auto still = by_ray(loopd::simulate_scan(drive.town, drive.model, s.T_world_sensor, drive.scan_seed(25), 2, s.visit), cols);
  int same_last = 0, rays_last = 0, moved_early = 0, rays_early = 0;
  for (const auto& [key, p] : moving) {
    const auto it = still.find(key);
    if (it == still.end()) continue;
    if (key.first == cols / 2 + 1) rays_last += 1, same_last += p == it->second ? 1 : 0;
    if (loopd::column_time_offset(key.first, cols, period) < -0.09) rays_early += 1, moved_early += (p - it->second).norm() > 0.05f ? 1 : 0;
  }
  CAPTURE(rays_last, rays_early, moved_early);
  CHECK(rays_last > 3);
  CHECK(same_last == rays_last);
  CHECK(moved_early > 0);
}

TEST_CASE("dropouts: the share of lost returns matches the rate, and more are lost far away", "[sim][effects][dropouts]") {
  const loopd::Town town = loopd::make_town(1);
  const loopd::LidarModel model = loopd::lidar_model_hdl64();
  const Eigen::Isometry3d T = loopd::street_pose(town, 0, 0, 0, 25.0);
  const loopd::SensorPoseAt at = [&T](double) { return T; };
  const loopd::PointCloud all = loopd::simulate_scan(town, model, T, 5, 2);

  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.dropouts = true;
  fx.dropout_rate = 0.1;
  fx.dropout_range_gain = fx.dropout_grazing_gain = fx.dropout_dark_gain = 0.0;
  const loopd::PointCloud flat = loopd::simulate_sweep(town, model, at, 0.1, fx, 5, 2);
  const double lost = 1.0 - static_cast<double>(flat.size()) / static_cast<double>(all.size());
  CAPTURE(all.size(), flat.size());
  CHECK(lost == Approx(0.1).margin(0.005));  // binomial sigma ~0.001 on ~125k returns

  // The same seed draws the same noise, so a kept return has exactly its range without dropouts.
  auto count = [](const loopd::PointCloud& c, double lo, double hi) {
    int n = 0;
    for (const auto& p : c.points) n += p.norm() >= lo && p.norm() < hi ? 1 : 0;
    return n;
  };
  auto lost_in = [&](const loopd::PointCloud& c, double lo, double hi) { return 1.0 - static_cast<double>(count(c, lo, hi)) / count(all, lo, hi); };
  // The range gain alone: x (1 + 2 (r / 120 m)^2), ~1.03 below 15 m, 1.2-3 beyond 40 m.
  fx.dropout_range_gain = 2.0;
  const loopd::PointCloud ranged = loopd::simulate_sweep(town, model, at, 0.1, fx, 5, 2);
  CHECK(lost_in(ranged, 0.0, 15.0) == Approx(0.1).margin(0.01));
  CHECK(lost_in(ranged, 40.0, 200.0) > 0.125);

  // Default gains: more lost far away, at grazing incidence (the ground) and on dark surfaces.
  const loopd::SensorEffects defaults;
  fx.dropout_rate = defaults.dropout_rate;
  fx.dropout_range_gain = defaults.dropout_range_gain;
  fx.dropout_grazing_gain = defaults.dropout_grazing_gain;
  fx.dropout_dark_gain = defaults.dropout_dark_gain;
  const loopd::PointCloud shaped = loopd::simulate_sweep(town, model, at, 0.1, fx, 5, 2);
  const double near = lost_in(shaped, 0.0, 15.0), far = lost_in(shaped, 40.0, 200.0);
  const double overall = 1.0 - static_cast<double>(shaped.size()) / static_cast<double>(all.size());
  WARN("lost returns with the default dropouts: near (< 15 m) " << near << ", far (> 40 m) " << far << ", overall " << overall);
  CHECK(far > near);
  CHECK(overall > defaults.dropout_rate);
  CHECK(overall < 0.2);
}

TEST_CASE("vegetation differs between two visits of the same place, static structure does not", "[sim][effects][vegetation]") {
  // A bush 8 m ahead in front of a wall 20 m ahead.
  loopd::Primitive bush;
  bush.type = loopd::PrimitiveType::kSphere;
  bush.a = bush.b = Eigen::Vector3d(8.0, 0.0, 1.0);
  bush.radius = 1.2;
  bush.reflectivity = 0.4f;
  bush.vegetation = bush.bush = true;
  const loopd::Town town = scene({box({20.0, -30.0, -1.0}, {21.0, 30.0, 10.0}), bush});
  const loopd::LidarModel model = clean_vlp16();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.0, 0.0, 1.8);
  const loopd::SensorPoseAt at = [&T](double) { return T; };
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.vegetation = true;
  // Two visits: the same pose, another scan seed.
  const loopd::PointCloud a = loopd::simulate_sweep(town, model, at, 0.1, fx, 101, 2);
  const loopd::PointCloud b = loopd::simulate_sweep(town, model, at, 0.1, fx, 202, 2);
  const loopd::PointCloud bare = loopd::simulate_scan(town, model, T, 101, 2);  // no vegetation: no bush

  auto in_bush = [&](const Eigen::Vector3f& p) {  // in the bush and above the ground (which the bush is sunk into)
    const Eigen::Vector3d w = p.cast<double>() + T.translation();
    return w.z() > 0.01 && (w - bush.a).norm() < bush.radius + 1e-3;
  };
  loopd::KdTree3f tree_b(b.points);
  int foliage = 0, foliage_same = 0, structure = 0, structure_same = 0;
  for (const auto& p : a.points) {
    int idx;
    float d2;
    const bool same = tree_b.nearest(p, &idx, &d2) && d2 < 1e-6f;
    if (in_bush(p)) {
      ++foliage, foliage_same += same ? 1 : 0;
    } else {
      ++structure, structure_same += same ? 1 : 0;
    }
  }
  // Rays that meet the bush: those of the scan without it whose line passes within its radius of its centre.
  int bare_in_bush = 0, meet = 0;
  for (const auto& p : bare.points) {
    bare_in_bush += in_bush(p) ? 1 : 0;
    const Eigen::Vector3d u = p.cast<double>().normalized(), c = bush.a - T.translation();
    meet += u.dot(c) > 0.0 && (c - u.dot(c) * u).norm() < bush.radius ? 1 : 0;
  }
  CAPTURE(foliage, foliage_same, structure, structure_same, meet);
  CHECK(bare_in_bush == 0);
  CHECK(foliage > 30);
  CHECK(foliage_same < foliage / 5);  // returns from a different depth inside the bush on every visit
  // The ground and the wall are the same points, but for the rays that one visit's foliage stopped and the other's let through.
  CHECK(structure_same > 0.98 * structure);
  // Foliage is porous: a good share of the rays that meet the bush go through it to the wall or the ground behind.
  CHECK(foliage > 0.3 * meet);
  CHECK(foliage < 0.9 * meet);

  // The town has bushes along the sidewalks, seen only with vegetation; crowns are solid without it.
  const loopd::Town t1 = loopd::make_town(1);
  int bushes = 0, crowns = 0;
  for (const auto& p : t1.primitives) bushes += p.bush ? 1 : 0, crowns += p.vegetation && !p.bush ? 1 : 0;
  CHECK(bushes > 100);
  CHECK(crowns > 50);
}

TEST_CASE("without effects a drive's scans are the instantaneous scans of before, bit for bit", "[sim][effects]") {
  loopd::DriveConfig cfg;
  cfg.sensor = "vlp16";
  cfg.num_scans = 30;
  cfg.effects = loopd::SensorEffects::none();
  const loopd::Drive drive = loopd::make_drive(cfg);
  for (int i : {0, 17, 29}) {
    const auto& s = drive.scans[static_cast<std::size_t>(i)];
    const loopd::PointCloud a = drive.simulate(i, 2);
    CHECK(identical(a, loopd::simulate_scan(drive.town, drive.model, s.T_world_sensor, drive.scan_seed(i), 1, s.visit)));
    CHECK_FALSE(a.has_time());
  }
  // Each effect alone changes the scan; all of them are deterministic for the seed, whatever the thread count.
  for (int e = 0; e < 4; ++e) {
    loopd::Drive one = drive;
    bool* flags[] = {&one.config.effects.motion_skew, &one.config.effects.dropouts, &one.config.effects.vegetation, &one.config.effects.point_times};
    *flags[e] = true;
    CAPTURE(e);
    CHECK_FALSE(identical(one.simulate(17, 2), drive.simulate(17, 2)));
  }
  loopd::Drive on = drive;
  on.config.effects = loopd::SensorEffects();
  CHECK(identical(on.simulate(17, 1), on.simulate(17, 2)));
  CHECK_FALSE(identical(on.simulate(17, 2), on.simulate(18, 2)));
  loopd::SensorEffects bad;
  bad.dropout_rate = 1.0;
  CHECK(bad.validate());
  bad = loopd::SensorEffects();
  bad.foliage_density = 0.0;
  CHECK(bad.validate());
  cfg.effects = bad;
  CHECK(cfg.validate());
}
