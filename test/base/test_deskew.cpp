// Deskew of a synthetic sweep: a static scene (ground, walls, boxes) scanned by a sensor that moves at 15 m/s and
// turns while its beam goes round once in 0.1 s. Each point is built with the true pose at its own time, so the
// deskewed scan must be the static scan seen from the pose at the stamp.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>

#include "loopd/base/deskew.hpp"

namespace {

using loopd::DeskewConfig;
using loopd::DeskewSkip;
using loopd::PointCloud;
using loopd::StampedPose;

constexpr std::int64_t kUtime = 1700000000000000;
constexpr double kPi = 3.14159265358979323846;

/// T_odom_sensor at t [s after the stamp].
using Motion = std::function<Eigen::Isometry3d(double)>;

/// On an arc: 15 m/s ahead, 1 m/s to the left and 0.2 m/s up in the sensor frame while yawing at 45 deg/s (a
/// constant velocity in the moving frame: the screw motion deskew interpolates is exact). Closed form: with
/// psi = psi0 + w t, dx/dt = vx cos psi - vy sin psi, dy/dt = vx sin psi + vy cos psi.
Eigen::Isometry3d straight_and_yawing(double t) {
  const double w = 45.0 * kPi / 180.0, psi0 = 0.3, psi = psi0 + w * t;
  const double vx = 15.0, vy = 1.0, vz = 0.2;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const double ds = std::sin(psi) - std::sin(psi0), dc = std::cos(psi) - std::cos(psi0);
  T.translation() = Eigen::Vector3d(5.0, 2.0, 1.8) + Eigen::Vector3d((vx * ds + vy * dc) / w, (-vx * dc + vy * ds) / w, vz * t);
  return T;
}

/// A car in a 30 m radius turn at 18 m/s (0.6 rad/s), heading along the path, pitching slightly.
Eigen::Isometry3d turning_car(double t) {
  const double radius = 30.0, rate = 0.6, a = rate * t;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(a + kPi / 2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.02 * std::sin(20 * t), Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(radius * std::cos(a) - radius, radius * std::sin(a), 1.8);
  return T;
}

/// Poses every `period` [s] from `from` to `to` (relative to the stamp).
std::vector<StampedPose> pose_stream(const Motion& motion, double from, double to, double period) {
  std::vector<StampedPose> out;
  for (double t = from; t <= to + 1e-9; t += period) {
    StampedPose p;
    p.utime = kUtime + static_cast<std::int64_t>(std::llround(t * 1e6));
    p.T_world_sensor = motion(static_cast<double>(p.utime - kUtime) * 1e-6);
    out.push_back(p);
  }
  return out;
}

/// World points of a static scene around the origin: ground, four walls, a few boxes.
std::vector<Eigen::Vector3d> scene() {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> w;
  for (int i = 0; i < 6000; ++i) w.emplace_back(-30 + 60 * u(rng), -30 + 60 * u(rng), 0.0);  // ground
  for (int i = 0; i < 2000; ++i) w.emplace_back(-30 + 60 * u(rng), 25.0, 6 * u(rng));        // walls
  for (int i = 0; i < 2000; ++i) w.emplace_back(-30 + 60 * u(rng), -25.0, 6 * u(rng));
  for (int i = 0; i < 2000; ++i) w.emplace_back(28.0, -25 + 50 * u(rng), 6 * u(rng));
  for (int i = 0; i < 2000; ++i) w.emplace_back(-28.0, -25 + 50 * u(rng), 6 * u(rng));
  for (int b = 0; b < 4; ++b)  // boxes
    for (int i = 0; i < 500; ++i) w.emplace_back(-10 + 8 * b + 2 * u(rng), 8.0 - 4 * b, 2 * u(rng));
  return w;
}

struct Scans {
  PointCloud skewed;     ///< what the sensor gives: each point in the sensor frame of its own time
  PointCloud reference;  ///< the same points in the sensor frame at the stamp
};

/// A sweep over [t_begin, t_begin + 0.1]: a point's time follows its azimuth from the sensor at the stamp.
Scans sweep(const Motion& motion, double t_begin) {
  Scans s;
  const Eigen::Isometry3d T0 = motion(0.0);
  for (const Eigen::Vector3d& w : scene()) {
    const Eigen::Vector3d q = T0.inverse() * w;
    const double azimuth = std::atan2(q.y(), q.x()) + kPi;  // 0 .. 2 pi
    const double t = t_begin + 0.1 * azimuth / (2 * kPi);
    const auto time = static_cast<float>(t);
    s.skewed.points.push_back((motion(time).inverse() * w).cast<float>());
    s.skewed.time.push_back(time);
    s.reference.points.push_back(q.cast<float>());
  }
  return s;
}

double max_error(const PointCloud& a, const PointCloud& b) {
  double e = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, static_cast<double>((a.points[i] - b.points[i]).norm()));
  return e;
}

bool same_bits(const PointCloud& a, const PointCloud& b) {
  return a.size() == b.size() && std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Eigen::Vector3f)) == 0;
}

}  // namespace

TEST_CASE("deskew recovers the static scan from the true pose stream") {
  const auto [name, motion, period] = GENERATE(table<const char*, Motion, double>({
      {"straight and yawing, 10 Hz poses", straight_and_yawing, 0.1},
      {"straight and yawing, 100 Hz poses", straight_and_yawing, 0.01},
      {"turning car, 100 Hz poses", turning_car, 0.01},
      {"turning car, 200 Hz poses", turning_car, 0.005},
  }));
  const int bins = GENERATE(0, 16, 64, 256);
  const double t_begin = GENERATE(-0.1, 0.0);  // stamped at the end of the sweep (the ROS driver's default) or its start
  INFO(name << ", " << bins << " bins, sweep from " << t_begin << " s");
  Scans s = sweep(motion, t_begin);
  REQUIRE(max_error(s.skewed, s.reference) > 1.0);  // the skew is real: metres at the sweep's far end
  DeskewConfig config;
  config.time_bins = bins;
  const auto r = loopd::deskew(config, pose_stream(motion, -0.3, 0.3, period), kUtime, &s.skewed);
  REQUIRE(r.applied());
  CHECK(r.points_moved > s.skewed.size() * 9 / 10);
  CHECK(r.max_correction > 1.0);
  CHECK(r.sweep == Approx(0.1).margin(1e-3));
  CHECK(r.extrapolated == 0.0);
  CHECK(max_error(s.skewed, s.reference) < 0.01);
  if (bins == 0) return;
  // The bins' own error: against every point with its own pose.
  Scans exact = sweep(motion, t_begin);
  config.time_bins = 0;
  REQUIRE(loopd::deskew(config, pose_stream(motion, -0.3, 0.3, period), kUtime, &exact.skewed).applied());
  CHECK(max_error(s.skewed, exact.skewed) < (bins < 64 ? 0.005 : 0.001));  // 16 bins: 3.4 mm on 100 Hz poses, 64: 0.9 mm
}

TEST_CASE("deskew leaves scans without times, with zero times, or when disabled bit for bit") {
  Scans s = sweep(straight_and_yawing, -0.1);
  const auto poses = pose_stream(straight_and_yawing, -0.3, 0.3, 0.1);
  DeskewConfig config;
  SECTION("no times") {
    PointCloud c = s.skewed;
    c.time.clear();
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kNoTimes);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("every time 0 (an instantaneous scan)") {
    PointCloud c = s.skewed;
    std::fill(c.time.begin(), c.time.end(), 0.0f);
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kNoSpan);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("disabled") {
    PointCloud c = s.skewed;
    config.enabled = false;
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kDisabled);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("times spanning more than max_sweep") {
    PointCloud c = s.skewed;
    c.time[0] = -0.7f;
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kSweepTooLong);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("a non-finite time leaves that point alone") {
    PointCloud c = s.skewed;
    c.time[5] = std::numeric_limits<float>::quiet_NaN();
    REQUIRE(loopd::deskew(config, poses, kUtime, &c).applied());
    CHECK(c.points[5] == s.skewed.points[5]);
    CHECK((c.points[6] - s.reference.points[6]).norm() < 0.01);
  }
}

TEST_CASE("poses that do not cover the sweep: extrapolated up to max_extrapolation, else the scan is left alone") {
  Scans s = sweep(straight_and_yawing, -0.1);
  DeskewConfig config;
  SECTION("poses from the stamp on: the sweep's 0.1 s before it extrapolated at the first pair's velocity") {
    const auto poses = pose_stream(straight_and_yawing, 0.0, 0.3, 0.1);
    PointCloud c = s.skewed;
    const auto r = loopd::deskew(config, poses, kUtime, &c);
    REQUIRE(r.applied());
    CHECK(r.extrapolated == Approx(0.1).margin(1e-3));
    CHECK(max_error(c, s.reference) < 0.01);  // constant velocity: extrapolation is exact here
    config.max_extrapolation = 0.05;
    c = s.skewed;
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kPosesDoNotCover);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("one pose gives no velocity") {
    PointCloud c = s.skewed;
    CHECK(loopd::deskew(config, pose_stream(straight_and_yawing, 0.0, 0.0, 0.1), kUtime, &c).skipped == DeskewSkip::kPosesDoNotCover);
    CHECK(same_bits(c, s.skewed));
  }
  SECTION("no poses") {
    PointCloud c = s.skewed;
    CHECK(loopd::deskew(config, {}, kUtime, &c).skipped == DeskewSkip::kPosesDoNotCover);
  }
  SECTION("a gap in the odometry across the sweep") {
    auto poses = pose_stream(straight_and_yawing, -0.6, 0.3, 0.1);
    poses.erase(poses.begin() + 2, poses.begin() + 6);  // -0.4 .. 0: 0.4 s without a pose
    PointCloud c = s.skewed;
    CHECK(loopd::deskew(config, poses, kUtime, &c).skipped == DeskewSkip::kPosesDoNotCover);
    CHECK(same_bits(c, s.skewed));
    config.max_pose_gap = 0.5;
    CHECK(loopd::deskew(config, poses, kUtime, &c).applied());
  }
}

TEST_CASE("PoseTrack interpolates, extrapolates and refuses gaps") {
  const auto poses = pose_stream(straight_and_yawing, -0.2, 0.2, 0.1);
  const loopd::PoseTrack track(poses, kUtime, 0.25);
  double beyond = -1;
  const auto exact = track.at(0.1, 0.0, &beyond);
  REQUIRE(exact);
  CHECK(exact->isApprox(poses[3].T_world_sensor));
  CHECK(beyond == 0.0);
  const auto mid = track.at(0.05, 0.0);
  REQUIRE(mid);
  CHECK((mid->translation() - straight_and_yawing(0.05).translation()).norm() < 1e-9);
  CHECK(loopd::rotation_angle(mid->inverse() * straight_and_yawing(0.05)) < 1e-9);
  CHECK_FALSE(track.at(0.3, 0.05));
  const auto ahead = track.at(0.3, 0.1, &beyond);
  REQUIRE(ahead);
  CHECK(beyond == Approx(0.1));
  CHECK((ahead->translation() - straight_and_yawing(0.3).translation()).norm() < 1e-9);
  CHECK(track.coverage(-0.2, 0.2, 0.0));
  CHECK_FALSE(loopd::PoseTrack(poses, kUtime, 0.05).coverage(-0.1, 0.1, 0.0));
}

TEST_CASE("DeskewConfig validates its fields") {
  DeskewConfig c;
  CHECK_FALSE(c.validate());
  c.max_sweep = 0.0;
  CHECK(c.validate());
  c = DeskewConfig();
  c.max_extrapolation = -1.0;
  CHECK(c.validate());
  c = DeskewConfig();
  c.max_pose_gap = std::nan("");
  CHECK(c.validate());
  c = DeskewConfig();
  c.time_bins = -1;
  CHECK(c.validate());
}
