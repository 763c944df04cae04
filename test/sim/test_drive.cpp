// Simulated drive: route with revisits (same / opposite direction, lane offset, long and short loop), ground truth,
// drifting odometry with residuals, determinism.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/kdtree.hpp"
#include "loopd/sim/drive.hpp"
#include "loopd/sim/gyro_sim.hpp"
#include "loopd/sim/odometry_stream.hpp"

namespace {
constexpr double kPi = 3.14159265358979323846;

double yaw_of(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d x = T.linear().col(0);
  return std::atan2(x.y(), x.x());
}
double angle_diff(double a, double b) {
  double d = std::fmod(a - b + 3.0 * kPi, 2.0 * kPi) - kPi;
  return std::abs(d);
}
}  // namespace

TEST_CASE("the drive route revisits places in all the required ways", "[sim][drive]") {
  loopd::DriveConfig cfg;
  cfg.num_scans = 1300;  // nearly a full lap (~1.37 km) at 1 m per scan
  const loopd::Drive d = loopd::make_drive(cfg);
  REQUIRE(d.error.empty());
  REQUIRE(static_cast<int>(d.scans.size()) == cfg.num_scans);
  CHECK(d.lap_length > 1000.0);
  CHECK(d.num_visits() == 3);
  CHECK(d.model.num_rings == 64);

  // 10 Hz, ~1 m spacing at 10 m/s, sensor 1.8 m above the ground.
  for (std::size_t i = 1; i < d.scans.size(); ++i) {
    CHECK(d.scans[i].utime - d.scans[i - 1].utime == 100000);
    const double step = (d.scans[i].T_world_sensor.translation() - d.scans[i - 1].T_world_sensor.translation()).norm();
    REQUIRE(step == Approx(1.0).margin(0.05));
  }
  for (const auto& s : d.scans) {
    const Eigen::Vector3d p = s.T_world_sensor.translation();
    REQUIRE(p.z() - d.town.ground_height(p.x(), p.y()) == Approx(1.8).margin(0.01));
  }

  // Classify revisits: for each scan, the nearest scan >= 100 scans earlier.
  int same_dir = 0, opposite = 0, lane_offset = 0;
  for (std::size_t i = 100; i < d.scans.size(); ++i) {
    double best = 1e9;
    std::size_t bj = 0;
    for (std::size_t j = 0; j + 100 <= i; ++j) {
      const double dist = (d.scans[i].T_world_sensor.translation() - d.scans[j].T_world_sensor.translation()).head<2>().norm();
      if (dist < best) best = dist, bj = j;
    }
    const double dyaw = angle_diff(yaw_of(d.scans[i].T_world_sensor), yaw_of(d.scans[bj].T_world_sensor));
    if (best < 1.0 && dyaw < 0.2) ++same_dir;
    if (best < 5.0 && dyaw > kPi - 0.2) ++opposite;  // the opposite lane is 4 m away
    if (best > 2.8 && best < 3.2 && dyaw < 0.1) ++lane_offset;
  }
  WARN("revisit scans: same direction " << same_dir << ", opposite direction " << opposite << ", lane offset (3 m) " << lane_offset);
  CHECK(same_dir > 50);
  CHECK(opposite > 100);
  CHECK(lane_offset > 10);
  CHECK(d.count_revisits(1.0, 100) >= same_dir);  // also counts crossings at intersections

  // Visits: 0 (short loop), 1 (opposite direction), 2 (long loop); visits change along the route.
  CHECK(d.scans.front().visit == 0);
  CHECK(d.scans.back().visit == 2);
  // The next lap counts on.
  loopd::DriveConfig cfg2 = cfg;
  cfg2.num_scans = static_cast<int>(d.lap_length) + 50;
  CHECK(loopd::make_drive(cfg2).scans.back().visit == 3);
}

TEST_CASE("odometry drifts, with higher residuals where drift was injected", "[sim][drive][odometry]") {
  loopd::DriveConfig cfg;
  cfg.num_scans = 1000;
  const loopd::Drive d = loopd::make_drive(cfg);
  auto error_at = [&](int i) {
    const auto& s = d.scans[static_cast<std::size_t>(i)];
    return (s.odometry.T_world_sensor.translation() - s.T_world_sensor.translation()).norm();
  };
  CHECK(error_at(0) == Approx(0.0).margin(1e-9));
  const double e100 = error_at(100), e500 = error_at(500), e999 = error_at(999);
  WARN("odometry error: scan 100 " << e100 << " m, 500 " << e500 << " m, 999 " << e999 << " m");
  // Loops partly cancel heading drift, so compare stretches rather than single poses.
  auto mean_error = [&](int from, int to) {
    double sum = 0;
    for (int i = from; i < to; ++i) sum += error_at(i);
    return sum / (to - from);
  };
  const double first = mean_error(0, 100), middle = mean_error(300, 500), last = mean_error(700, 1000);
  WARN("mean odometry error: scans 0-99 " << first << " m, 300-499 " << middle << " m, 700-999 " << last << " m");
  CHECK(first < middle);
  CHECK(3.0 * first < last);
  CHECK(e999 > 1.0);
  CHECK(e999 < 0.1 * d.route_length());  // realistic: a few percent of the distance

  double res_clean = 0.0, res_degraded = 0.0;
  int n_clean = 0, n_degraded = 0;
  for (std::size_t i = 1; i < d.scans.size(); ++i) {
    const auto& s = d.scans[i];
    CHECK(s.odometry.utime == s.utime);
    CHECK(s.odometry.residual > 0.0);
    (s.degraded ? res_degraded : res_clean) += s.odometry.residual;
    (s.degraded ? n_degraded : n_clean) += 1;
  }
  REQUIRE(n_degraded > 0);
  REQUIRE(n_clean > 0);
  res_clean /= n_clean;
  res_degraded /= n_degraded;
  WARN("mean residual: clean steps " << res_clean << " m, degraded steps " << res_degraded << " m");
  CHECK(res_degraded > 3.0 * res_clean);
  // Residual follows the injected error step by step (rank agreement on a sample).
  double cov = 0, va = 0, vb = 0, ma = 0, mb = 0;
  const double n = static_cast<double>(d.scans.size() - 1);
  for (std::size_t i = 1; i < d.scans.size(); ++i) ma += d.scans[i].injected_error / n, mb += d.scans[i].odometry.residual / n;
  for (std::size_t i = 1; i < d.scans.size(); ++i) {
    const double a = d.scans[i].injected_error - ma, b = d.scans[i].odometry.residual - mb;
    cov += a * b, va += a * a, vb += b * b;
  }
  CHECK(cov / std::sqrt(va * vb) > 0.9);

  // No drift configured -> odometry equals ground truth.
  loopd::DriveConfig clean = cfg;
  clean.num_scans = 200;
  clean.heading_bias_deg_per_100m = 0;
  clean.scale_bias = 0;
  clean.yaw_random_walk_deg = 0;
  clean.translation_noise = 0;
  clean.pitch_roll_noise_deg = 0;
  const loopd::Drive c = loopd::make_drive(clean);
  CHECK((c.scans.back().odometry.T_world_sensor.translation() - c.scans.back().T_world_sensor.translation()).norm() < 1e-6);
}

TEST_CASE("drives are deterministic for a seed and validate their config", "[sim][drive]") {
  loopd::DriveConfig cfg;
  cfg.num_scans = 300;
  cfg.sensor = "vlp16";
  const auto a = loopd::make_drive(cfg);
  const auto b = loopd::make_drive(cfg);
  cfg.seed = 2;
  const auto c = loopd::make_drive(cfg);
  REQUIRE(a.scans.size() == b.scans.size());
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    REQUIRE(a.scans[i].T_world_sensor.matrix() == b.scans[i].T_world_sensor.matrix());
    REQUIRE(a.scans[i].odometry.T_world_sensor.matrix() == b.scans[i].odometry.T_world_sensor.matrix());
    REQUIRE(a.scans[i].odometry.residual == b.scans[i].odometry.residual);
  }
  CHECK((a.scans.back().T_world_sensor.translation() - c.scans.back().T_world_sensor.translation()).norm() > 0.5);
  const auto s1 = a.simulate(42, 1), s2 = b.simulate(42, 2);
  CHECK(s1.points == s2.points);
  CHECK(s1.num_rings == 16);

  loopd::DriveConfig bad;
  bad.sensor = "nope";
  CHECK(bad.validate());
  CHECK_FALSE(loopd::make_drive(bad).error.empty());
  bad = loopd::DriveConfig{};
  bad.speed = -1;
  CHECK(bad.validate());
}

TEST_CASE("a revisit of the drive overlaps its earlier visit after ground-truth alignment", "[sim][drive][overlap]") {
  loopd::DriveConfig cfg;
  cfg.num_scans = 1000;
  const loopd::Drive d = loopd::make_drive(cfg);
  // The revisit pair with the closest ground truth between visit 1 (second pass of (0,1)->(0,0)) and visit 0.
  double best = 1e9;
  int qi = -1, mi = -1;
  for (int i = 0; i < cfg.num_scans; ++i) {
    if (d.scans[static_cast<std::size_t>(i)].visit != 1) continue;
    for (int j = 0; j + 100 <= i; ++j) {
      if (d.scans[static_cast<std::size_t>(j)].visit != 0) continue;
      const double dist =
          (d.scans[static_cast<std::size_t>(i)].T_world_sensor.translation() - d.scans[static_cast<std::size_t>(j)].T_world_sensor.translation())
              .norm();
      // A place in the middle of a revisited stretch, not a crossing.
      if (dist < 0.5 && dist < best && i > 600) best = dist, qi = i, mi = j;
    }
  }
  REQUIRE(qi >= 0);
  const auto q = loopd::transform(loopd::voxel_downsample(d.simulate(qi, 2), 0.05), d.scans[static_cast<std::size_t>(qi)].T_world_sensor);
  const auto m = loopd::transform(loopd::voxel_downsample(d.simulate(mi, 2), 0.05), d.scans[static_cast<std::size_t>(mi)].T_world_sensor);
  loopd::KdTree3f tree(m.points);
  std::size_t close = 0;
  for (const auto& p : q.points) {
    int idx;
    float d2;
    if (tree.nearest(p, &idx, &d2) && d2 <= 0.09f) ++close;
  }
  const double share = static_cast<double>(close) / static_cast<double>(q.size());
  WARN("scan " << qi << " (visit 1) vs scan " << mi << " (visit 0), " << best << " m apart: " << share << " within 0.3 m");
  CHECK(share >= 0.70);
}

TEST_CASE("a gyro on the drive turns as the ground truth turned, and odometry between the scans keeps the scans' poses", "[sim][drive][imu]") {
  loopd::DriveConfig cfg;
  cfg.num_scans = 200;
  cfg.sensor = "vlp16";
  cfg.route = "block";
  const loopd::Drive drive = loopd::make_drive(cfg);
  loopd::GyroSimConfig perfect;
  perfect.noise_deg_s = 0.0;
  perfect.bias_deg_s = 0.0;
  // Integrated over every sweep, a noise-free gyro gives back the true rotation from scan to scan (a corner included).
  double largest_turn = 0.0;
  for (int i = 1; i < cfg.num_scans; ++i) {
    std::vector<loopd::ImuSample> samples = loopd::simulate_gyro(drive, perfect, i - 1);
    REQUIRE(samples.size() == 20);  // 200 Hz over a 0.1 s sweep
    CHECK(samples.back().utime == drive.scans[static_cast<std::size_t>(i - 1)].utime);
    const std::vector<loopd::ImuSample> next = loopd::simulate_gyro(drive, perfect, i);
    samples = {samples.back()};
    samples.insert(samples.end(), next.begin(), next.end());
    const auto track = loopd::integrate_gyro(samples, Eigen::Matrix3d::Identity(), 0.05);
    const Eigen::Matrix3d truth = drive.scans[static_cast<std::size_t>(i - 1)].T_world_sensor.linear().transpose() *
                                  drive.scans[static_cast<std::size_t>(i)].T_world_sensor.linear();
    const Eigen::Matrix3d turned = track.back().T_world_sensor.linear();
    CHECK(Eigen::AngleAxisd(truth.transpose() * turned).angle() < 1e-9);
    largest_turn = std::max(largest_turn, Eigen::AngleAxisd(truth).angle());
  }
  CHECK(largest_turn * 180.0 / kPi > 3.0);  // the drive turned a corner
  // Noise and a bias within the configured bound, seeded: the same drive gives the same samples.
  const loopd::GyroSimConfig noisy;
  const auto a = loopd::simulate_gyro(drive, noisy, 50), b = loopd::simulate_gyro(drive, noisy, 50), p = loopd::simulate_gyro(drive, perfect, 50);
  REQUIRE(a.size() == p.size());
  double largest = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    CHECK(a[k].angular_velocity == b[k].angular_velocity);
    largest = std::max(largest, (a[k].angular_velocity - p[k].angular_velocity).cwiseAbs().maxCoeff());
  }
  CHECK(largest > 0.0);
  CHECK(largest * 180.0 / kPi < 0.05 + 5.0 * 0.1);  // bias bound + 5 sigma of noise
  CHECK(loopd::simulate_gyro(drive, loopd::GyroSimConfig{0.0}, 50).empty());

  // Odometry at 100 Hz: nine poses between two scans, the step's drift spread evenly; at the scans the drive's own.
  const auto between = loopd::odometry_between_scans(drive, 120, 100.0);
  REQUIRE(between.size() == 9);
  const auto& s0 = drive.scans[119];
  const auto& s1 = drive.scans[120];
  CHECK(between.front().utime == s0.utime + 10000);
  CHECK(between.back().utime == s1.utime - 10000);
  const Eigen::Isometry3d drift =
      (s0.T_world_sensor.inverse() * s1.T_world_sensor).inverse() * (s0.odometry.T_world_sensor.inverse() * s1.odometry.T_world_sensor);
  const Eigen::Isometry3d half = s0.odometry.T_world_sensor * (s0.T_world_sensor.inverse() * drive.pose_at_distance(s0.route_distance + 0.5)) *
                                 loopd::interpolate_screw(Eigen::Isometry3d::Identity(), drift, 0.5);
  CHECK((between[4].T_world_sensor.translation() - half.translation()).norm() < 1e-9);
  CHECK(loopd::odometry_between_scans(drive, 0, 100.0).empty());
  CHECK(loopd::odometry_between_scans(drive, 120, 10.0).empty());  // not above the scan rate
}
