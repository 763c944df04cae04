// The sweep's motion from the scans: two consecutive simulated HDL-64E sweeps of a sensor driving at 10 m/s while
// yawing at 30 deg/s on an arc (a constant velocity in its own frame: the motion model is exact), registered from an
// odometry increment with the step noise of a degraded stretch. The scans must give back the true increment; a deskew with it must match the
// scan the sensor would have seen standing still at the stamp better than a deskew with the odometry's.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "loopd/base/deskew.hpp"
#include "loopd/base/imu.hpp"
#include "loopd/base/kdtree.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/registration/sweep_motion.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kPeriod = 0.1;  // [s] one sweep, and the time between the two stamps
constexpr std::int64_t kUtime = 1700000000000000;

/// The sensor at t [s after the previous scan's stamp]: 10 m/s along its heading while yawing at 30 deg/s, a car on
/// a 19 m arc (a constant velocity in its own frame: x = R sin(w t), y = R (1 - cos(w t)), R = v / w).
Eigen::Isometry3d motion(double t) {
  const double v = 10.0, w = 30.0 * kPi / 180.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(w * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(v / w * std::sin(w * t), v / w * (1.0 - std::cos(w * t)), 0.0);
  return T;
}

struct TwoSweeps {
  loopd::Town town = loopd::make_town(1);
  Eigen::Isometry3d T_world_start = loopd::street_pose(town, 0, 0, 0, 25.0);
  loopd::PointCloud previous, current, current_still;  ///< still: instantaneous at the current stamp
  Eigen::Isometry3d T_previous_current = motion(0.0).inverse() * motion(kPeriod);
};

TwoSweeps make_sweeps() {
  TwoSweeps s;
  const loopd::LidarModel model = loopd::lidar_model_hdl64();
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.motion_skew = true;
  fx.point_times = true;
  const Eigen::Isometry3d T0 = s.T_world_start;
  s.previous = loopd::simulate_sweep(
      s.town, model, [&](double t) { return T0 * motion(t); }, kPeriod, fx, 1, 2);
  s.current = loopd::simulate_sweep(
      s.town, model, [&](double t) { return T0 * motion(kPeriod + t); }, kPeriod, fx, 2, 2);
  s.current_still = loopd::simulate_scan(s.town, model, T0 * motion(kPeriod), 2, 2);
  return s;
}

/// The odometry's increment: the truth with 0.3 deg of yaw and 8 cm of step noise (a degraded stretch).
Eigen::Isometry3d noisy(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d N = Eigen::Isometry3d::Identity();
  N.linear() = Eigen::AngleAxisd(0.3 * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  N.translation() = Eigen::Vector3d(0.06, -0.05, 0.01);
  return T * N;
}

double rotation_deg(const Eigen::Isometry3d& T) { return loopd::rotation_angle(T) * 180.0 / kPi; }

/// Mean distance of a deskewed sweep's points (within 40 m) to the same rays of the still scan: the simulator's
/// column-major order with the same rays is not kept by a sweep, so the nearest still point within 1 m stands in.
double mean_distance_to_still(const loopd::PointCloud& deskewed, const loopd::PointCloud& still) {
  const loopd::KdTree3f tree(still.points);
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < deskewed.size(); i += 7) {
    const Eigen::Vector3f& p = deskewed.points[i];
    if (p.norm() > 40.0f) continue;
    int nearest = -1;
    float dist_sq = 1.0f;
    const bool found = tree.nearest(p, &nearest, &dist_sq);
    sum += found ? std::min(1.0, std::sqrt(static_cast<double>(dist_sq))) : 1.0;  // capped at 1 m, as an unmatched point
    ++n;
  }
  return n > 0 ? sum / n : 1.0;
}

loopd::PointCloud deskewed_with(const loopd::PointCloud& sweep, const Eigen::Isometry3d& T_previous_current) {
  loopd::PointCloud c = sweep;
  const std::vector<loopd::StampedPose> poses{{kUtime, T_previous_current.inverse(), 0.0}, {kUtime + 100000, Eigen::Isometry3d::Identity(), 0.0}};
  const loopd::DeskewResult r = loopd::deskew(loopd::DeskewConfig{}, poses, kUtime + 100000, &c);
  REQUIRE(r.applied());
  return c;
}

/// Straight at 10 m/s until `onset` [s after the previous stamp], then a 60 deg/s arc: the turn rate steps inside the
/// current sweep, as at a corner's entry.
Eigen::Isometry3d onset_motion(double t, double onset) {
  const double v = 10.0, w = 60.0 * kPi / 180.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (t <= onset) {
    T.translation() = Eigen::Vector3d(v * t, 0.0, 0.0);
    return T;
  }
  const double a = w * (t - onset);
  T.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(v * onset + v / w * std::sin(a), v / w * (1.0 - std::cos(a)), 0.0);
  return T;
}

/// The current sweep deskewed on a path given as poses in the previous stamp's frame at times [s] relative to the
/// current stamp (the last one the stamp's own pose).
loopd::PointCloud deskewed_on(const loopd::PointCloud& sweep, const std::vector<double>& times,
                              const std::vector<Eigen::Isometry3d>& T_previous_sensor) {
  std::vector<loopd::StampedPose> poses;
  for (std::size_t k = 0; k < times.size(); ++k) poses.push_back({kUtime + 100000 + std::llround(times[k] * 1e6), T_previous_sensor[k], 0.0});
  loopd::PointCloud c = sweep;
  REQUIRE(loopd::deskew(loopd::DeskewConfig{}, poses, kUtime + 100000, &c).applied());
  return c;
}

}  // namespace

TEST_CASE("the scans give back a sweep's motion that noisy odometry got wrong", "[registration][sweep_motion]") {
  const TwoSweeps s = make_sweeps();
  const Eigen::Isometry3d odometry = noisy(s.T_previous_current);
  // The increment between the stamps, with one turn rate (the model is exact on this arc).
  loopd::SweepMotionConfig one_rate;
  one_rate.shape.segments = 0;
  const loopd::SweepMotionResult r = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, one_rate);
  INFO(r.reason);
  REQUIRE(r.refined);
  CHECK_FALSE(r.shape_refined);
  const Eigen::Isometry3d error = s.T_previous_current.inverse() * r.T_previous_current;
  const Eigen::Isometry3d odometry_error = s.T_previous_current.inverse() * odometry;
  CAPTURE(error.translation().transpose(), rotation_deg(error), r.degeneracy, r.fitness, r.weak_direction_from_odometry);
  CHECK(rotation_deg(odometry_error) == Approx(0.3).margin(1e-6));
  CHECK(rotation_deg(error) < 0.03);  // 10x better than the odometry's
  if (!r.weak_direction_from_odometry) CHECK(error.translation().norm() < 0.02);
  CHECK(r.rotation_change_deg == Approx(0.3).margin(0.03));

  // Deskewed with it, the sweep lies on the scan seen standing still at the stamp closer than with the odometry's.
  const double with_scans = mean_distance_to_still(deskewed_with(s.current, r.T_previous_current), s.current_still);
  const double with_odometry = mean_distance_to_still(deskewed_with(s.current, odometry), s.current_still);
  const double with_truth = mean_distance_to_still(deskewed_with(s.current, s.T_previous_current), s.current_still);
  CAPTURE(with_scans, with_odometry, with_truth);
  CHECK(with_scans < with_odometry);
  CHECK(with_scans < with_truth + 0.005);
  // The odometry turned by the same over the previous sweep (an arc): one rate holds, the shape is not refined;
  // nor without the previous sweep's odometry (the rate change unknown).
  const loopd::SweepIncrement same_rate{odometry, kPeriod};
  CHECK_FALSE(loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, loopd::SweepMotionConfig{}, same_rate).shape_refined);
  CHECK_FALSE(loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, loopd::SweepMotionConfig{}).shape_refined);
  // Made to refine it anyway (min_rate_change_deg 0), two turn rates on an arc that has one: the stamp's rotation
  // stays within 0.1 deg, the deskewed sweep as close to the still scan.
  loopd::SweepMotionConfig two_rates;
  two_rates.shape.segments = 2;
  two_rates.shape.min_rate_change_deg = 0.0;
  const loopd::SweepMotionResult shaped = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, two_rates, same_rate);
  REQUIRE(shaped.shape_refined);
  CHECK(rotation_deg(s.T_previous_current.inverse() * shaped.T_previous_current) < 0.1);
  CHECK(mean_distance_to_still(deskewed_on(s.current, shaped.knot_times, shaped.T_previous_knot), s.current_still) < with_truth + 0.005);
  WARN("sweep motion: rotation error " << rotation_deg(error) << " deg, translation " << error.translation().norm() << " m; deskewed " << with_scans
                                       << " m from the still scan (odometry " << with_odometry << ", truth " << with_truth << ")");
}

TEST_CASE("the sweep's motion keeps the odometry's where the scans cannot say or disagree", "[registration][sweep_motion]") {
  const TwoSweeps s = make_sweeps();
  const Eigen::Isometry3d odometry = noisy(s.T_previous_current);

  loopd::PointCloud untimed = s.current;
  untimed.time.clear();
  loopd::SweepMotionResult r = loopd::estimate_sweep_motion(s.previous, untimed, kPeriod, odometry, loopd::SweepMotionConfig{});
  CHECK_FALSE(r.refined);
  CHECK(r.reason.find("per-point times") != std::string::npos);
  CHECK(r.T_previous_current.isApprox(odometry));

  r = loopd::estimate_sweep_motion(s.previous, s.current, 0.0, odometry, loopd::SweepMotionConfig{});
  CHECK_FALSE(r.refined);
  CHECK(r.reason.find("no time") != std::string::npos);

  loopd::PointCloud empty;
  empty.points = {Eigen::Vector3f(5, 0, 0)};
  empty.time = {0.0f};
  r = loopd::estimate_sweep_motion(s.previous, empty, kPeriod, odometry, loopd::SweepMotionConfig{});
  CHECK_FALSE(r.refined);
  CHECK(r.reason.find("too few points") != std::string::npos);

  // The scans register (to the truth), but 0.3 deg from the odometry is more than this config believes.
  loopd::SweepMotionConfig strict;
  strict.max_rotation_change_deg = 0.1;
  r = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, strict);
  CHECK_FALSE(r.refined);
  CHECK(r.reason.find("from the odometry's") != std::string::npos);
  CHECK(r.T_previous_current.isApprox(odometry));

  loopd::SweepMotionConfig bad;
  bad.voxel_size = 0.0;
  r = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, bad);
  CHECK_FALSE(r.refined);
  CHECK(r.reason.find("voxel_size") != std::string::npos);
}

TEST_CASE("a degenerate registration keeps the odometry's translation along its weakest direction only", "[registration][sweep_motion]") {
  const TwoSweeps s = make_sweeps();
  const Eigen::Isometry3d odometry = noisy(s.T_previous_current);  // 8 cm off
  loopd::SweepMotionConfig one_rate;
  one_rate.shape.segments = 0;
  const loopd::SweepMotionResult free = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, one_rate);
  REQUIRE(free.refined);
  REQUIRE_FALSE(free.weak_direction_from_odometry);
  // The same registration judged degenerate (any condition number above 1 is, here).
  loopd::SweepMotionConfig strict = one_rate;
  strict.max_degeneracy = 1.0;
  const loopd::SweepMotionResult r = loopd::estimate_sweep_motion(s.previous, s.current, kPeriod, odometry, strict);
  INFO(r.reason);
  REQUIRE(r.refined);
  REQUIRE(r.weak_direction_from_odometry);
  CHECK_FALSE(r.translation_from_odometry);
  const Eigen::Vector3d d = r.weak_direction;
  CHECK(d.norm() == Approx(1.0).margin(1e-9));
  const Eigen::Vector3d t = r.T_previous_current.translation(), t_free = free.T_previous_current.translation();
  const Eigen::Vector3d t_odometry = odometry.translation(), t_true = s.T_previous_current.translation();
  CAPTURE(d.transpose(), t.transpose(), t_free.transpose(), t_odometry.transpose(), t_true.transpose(), r.degeneracy);
  // Along d the odometry's, across it the scans' (to the micrometre), and the rotation the scans' either way.
  CHECK(std::abs(d.dot(t - t_odometry)) < 1e-9);
  CHECK(((t - t_free) - d * d.dot(t - t_free)).norm() < 1e-9);
  CHECK(loopd::rotation_angle(free.T_previous_current.inverse() * r.T_previous_current) < 1e-12);
  // So it lies nearer the truth than the odometry's: only the odometry's error along d is left.
  const Eigen::Vector3d odometry_error = t_odometry - t_true;
  CHECK((t - t_true).norm() < odometry_error.norm());
  CHECK((t - t_true).norm() == Approx(std::abs(d.dot(odometry_error))).margin(0.02));
}

TEST_CASE("at a turn's onset the previous sweep is deskewed at its own turn rate from the odometry", "[registration][sweep_motion]") {
  // Straight at 10 m/s through the previous sweep, then the 30 deg/s arc from the previous stamp on: the turn rate
  // steps by 3 deg per sweep, so one constant velocity over both sweeps fits neither.
  loopd::Town town = loopd::make_town(1);
  const Eigen::Isometry3d T0 = loopd::street_pose(town, 0, 0, 0, 25.0);
  const auto straight = [](double t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(10.0 * t, 0.0, 0.0);
    return T;
  };
  const loopd::LidarModel model = loopd::lidar_model_hdl64();
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.motion_skew = true;
  fx.point_times = true;
  const loopd::PointCloud previous = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * straight(t); }, kPeriod, fx, 1, 2);
  const loopd::PointCloud current = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * motion(kPeriod + t); }, kPeriod, fx, 2, 2);
  const Eigen::Isometry3d truth = motion(kPeriod);
  const loopd::SweepIncrement previous_sweep{straight(-kPeriod).inverse() * straight(0.0), kPeriod};
  const Eigen::Isometry3d odometry = noisy(truth);

  const loopd::SweepMotionResult constant = loopd::estimate_sweep_motion(previous, current, kPeriod, odometry, loopd::SweepMotionConfig{});
  const loopd::SweepMotionResult changed =
      loopd::estimate_sweep_motion(previous, current, kPeriod, odometry, loopd::SweepMotionConfig{}, previous_sweep);
  INFO(constant.reason << " / " << changed.reason);
  REQUIRE(changed.refined);
  CHECK(changed.velocity_changed);
  CHECK_FALSE(constant.velocity_changed);
  const Eigen::Isometry3d error_changed = truth.inverse() * changed.T_previous_current;
  const Eigen::Isometry3d error_constant = truth.inverse() * constant.T_previous_current;
  CAPTURE(rotation_deg(error_changed), rotation_deg(error_constant), error_changed.translation().norm(), error_constant.translation().norm());
  // What remains is the current sweep deskewed under the odometry's noisy increment for the one round (0.3 deg).
  CHECK(rotation_deg(error_changed) < 0.25);
  CHECK(rotation_deg(error_changed) < 0.2 * rotation_deg(error_constant));
  CHECK(error_changed.translation().norm() < 0.25 * error_constant.translation().norm());
  WARN("turn onset: rotation error " << rotation_deg(error_changed) << " deg (one velocity over both sweeps: " << rotation_deg(error_constant)
                                     << "), translation " << error_changed.translation().norm() << " m (" << error_constant.translation().norm()
                                     << ")");

  // Below min_velocity_change_deg (the odometry's step noise) both sweeps share the estimate's velocity.
  loopd::SweepMotionConfig deaf;
  deaf.min_velocity_change_deg = 5.0;
  CHECK_FALSE(loopd::estimate_sweep_motion(previous, current, kPeriod, odometry, deaf, previous_sweep).velocity_changed);
}

TEST_CASE("a turn's onset inside the sweep: its rotation with two turn rates lies closer to the truth than one", "[registration][sweep_motion]") {
  loopd::Town town = loopd::make_town(1);
  const Eigen::Isometry3d T0 = loopd::street_pose(town, 0, 0, 0, 25.0);
  const double onset = 0.05;  // halfway through the current sweep
  const loopd::LidarModel model = loopd::lidar_model_hdl64();
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.motion_skew = true;
  fx.point_times = true;
  const loopd::PointCloud previous = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * onset_motion(t, onset); }, kPeriod, fx, 1, 2);
  const loopd::PointCloud current = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * onset_motion(kPeriod + t, onset); }, kPeriod, fx, 2, 2);
  const loopd::PointCloud still = loopd::simulate_scan(town, model, T0 * onset_motion(kPeriod, onset), 2, 2);
  const Eigen::Isometry3d truth = onset_motion(kPeriod, onset);
  const loopd::SweepIncrement previous_sweep{onset_motion(-kPeriod, onset).inverse() * onset_motion(0.0, onset), kPeriod};

  loopd::SweepMotionConfig one_rate;
  one_rate.shape.segments = 0;
  const loopd::SweepMotionResult constant = loopd::estimate_sweep_motion(previous, current, kPeriod, truth, one_rate, previous_sweep);
  loopd::SweepMotionConfig two_rates;
  two_rates.shape.segments = 2;
  const loopd::SweepMotionResult shaped = loopd::estimate_sweep_motion(previous, current, kPeriod, truth, two_rates, previous_sweep);
  INFO(constant.reason << " / " << shaped.reason);
  REQUIRE(constant.refined);
  REQUIRE(shaped.refined);
  REQUIRE(shaped.shape_refined);
  REQUIRE(shaped.knot_times.size() == 3);
  CHECK(shaped.knot_times.back() == Approx(0.0).margin(1e-3));  // the sweep ends at its stamp

  // Each knot's rotation against the truth at its time: the constant rate misses the mid-sweep one by about a quarter
  // of the sweep's 3 deg.
  double worst_shaped = 0.0, worst_constant = 0.0;
  for (std::size_t k = 0; k < shaped.knot_times.size(); ++k) {
    const double t = kPeriod + shaped.knot_times[k];
    const Eigen::Isometry3d T_true = onset_motion(t, onset);
    const Eigen::Isometry3d T_constant = loopd::interpolate_screw(Eigen::Isometry3d::Identity(), constant.T_previous_current, t / kPeriod);
    worst_shaped = std::max(worst_shaped, rotation_deg(T_true.inverse() * shaped.T_previous_knot[k]));
    worst_constant = std::max(worst_constant, rotation_deg(T_true.inverse() * T_constant));
  }
  CAPTURE(worst_shaped, worst_constant, shaped.shape_correction_deg);
  CHECK(worst_constant > 0.4);
  CHECK(worst_shaped < 0.5 * worst_constant);
  // yaw_only (the default): each knot is the constant-velocity path turned about the sensor's z axis only.
  for (std::size_t k = 0; k < shaped.knot_times.size(); ++k) {
    const double tau = (kPeriod + shaped.knot_times[k]) / kPeriod;
    const Eigen::Isometry3d T_path = loopd::interpolate_screw(Eigen::Isometry3d::Identity(), constant.T_previous_current, tau);
    const Eigen::Matrix3d turn = T_path.linear().transpose() * shaped.T_previous_knot[k].linear();
    CHECK((turn.col(2) - Eigen::Vector3d::UnitZ()).norm() < 1e-9);
  }
  // With the previous sweep turning as this one ends (no change of rate), the shape is not refined.
  const loopd::SweepIncrement no_change{truth, kPeriod};
  CHECK_FALSE(loopd::estimate_sweep_motion(previous, current, kPeriod, truth, two_rates, no_change).shape_refined);

  std::vector<double> times = shaped.knot_times;
  std::vector<Eigen::Isometry3d> path = shaped.T_previous_knot;
  const loopd::PointCloud with_shape = deskewed_on(current, times, path);
  const loopd::PointCloud with_constant = deskewed_on(current, {-kPeriod, 0.0}, {Eigen::Isometry3d::Identity(), constant.T_previous_current});
  const double d_shape = mean_distance_to_still(with_shape, still), d_constant = mean_distance_to_still(with_constant, still);
  CAPTURE(d_shape, d_constant);
  CHECK(d_shape < 0.8 * d_constant);
  WARN("turn onset inside the sweep: knot rotation error " << worst_shaped << " deg (one rate: " << worst_constant << "); deskewed " << d_shape
                                                           << " m from the still scan (one rate: " << d_constant << ")");
}

namespace {

/// A gyro riding with the sensor on `path` (t [s] after the previous stamp): at 200 Hz from t0 to t1, each sample the
/// mean turn rate over the period before it, in the sensor frame; utimes on the scans' clock.
std::vector<loopd::ImuSample> gyro_on(const std::function<Eigen::Isometry3d(double)>& path, double t0, double t1) {
  std::vector<loopd::ImuSample> samples;
  const double h = 0.005;
  for (int k = 0; t0 + k * h <= t1 + 1e-9; ++k) {
    const double t = t0 + k * h;
    const Eigen::AngleAxisd turn(path(t - h).linear().transpose() * path(t).linear());
    samples.push_back({kUtime + std::llround(t * 1e6), turn.axis() * turn.angle() / h});
  }
  return samples;
}

}  // namespace

TEST_CASE("a gyro integrates to the rotation it turned, in the lidar's frame, and its path curves at the speed given", "[registration][imu]") {
  // 30 deg/s about the IMU's x axis, mounted with that axis along the lidar's z (pitched by -90 deg): 3 deg about z
  // in 0.1 s; at 10 m/s along x the dead-reckoned path is the arc of radius v / w.
  const double w = 30.0 * kPi / 180.0, v = 10.0;
  std::vector<loopd::ImuSample> samples;
  for (int k = 0; k <= 20; ++k) samples.push_back({kUtime + k * 5000, Eigen::Vector3d(w, 0.0, 0.0)});
  const Eigen::Matrix3d R_sensor_imu = loopd::rotation_from_rpy_deg(0.0, -90.0, 0.0);
  CHECK((R_sensor_imu * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitZ()).norm() < 1e-12);
  const std::vector<loopd::StampedPose> track = loopd::integrate_gyro(samples, R_sensor_imu, 0.05, Eigen::Vector3d(v, 0.0, 0.0));
  REQUIRE(track.size() == samples.size());
  const Eigen::Isometry3d end = track.back().T_world_sensor;
  const Eigen::AngleAxisd turned(end.linear());
  CHECK(turned.angle() * 180.0 / kPi == Approx(3.0).margin(1e-9));
  CHECK(turned.axis().z() == Approx(1.0).margin(1e-9));
  const double a = w * 0.1;
  CHECK((end.translation() - Eigen::Vector3d(v / w * std::sin(a), v / w * (1.0 - std::cos(a)), 0.0)).norm() < 1e-6);
  const auto rotation = loopd::gyro_rotation(track, kUtime + 50000, kUtime + 100000, 0.05);
  REQUIRE(rotation);
  CHECK(Eigen::AngleAxisd(*rotation).angle() * 180.0 / kPi == Approx(1.5).margin(1e-9));
  CHECK_FALSE(loopd::gyro_rotation(track, kUtime - 5000, kUtime + 100000, 0.05));  // before the first sample
  // A gap longer than max_gap ends the track there.
  samples[12].utime += 60000;
  for (std::size_t k = 13; k < samples.size(); ++k) samples[k].utime += 60000;
  CHECK(loopd::integrate_gyro(samples, Eigen::Matrix3d::Identity(), 0.05).size() == 12);
}

TEST_CASE("a sweep's bend: none at a constant velocity, a turn's onset from the poses inside the sweep", "[registration][imu]") {
  const auto track = [](const std::function<Eigen::Isometry3d(double)>& path) {
    std::vector<loopd::StampedPose> poses;
    for (int k = 0; k <= 40; ++k) poses.push_back({kUtime + k * 5000, path(k * 0.005), 0.0});  // from the previous stamp to the current
    return poses;
  };
  const std::int64_t stamp = kUtime + 100000;
  const loopd::SweepBend arc = loopd::SweepBend::from_poses(track(motion), stamp + 100000, kPeriod, 0.25);
  REQUIRE_FALSE(arc.empty());
  CHECK(arc.max_rotation_deg() < 1e-6);  // a constant velocity: the screw motion itself
  const auto onset = [](double t) { return onset_motion(t, 0.05); };
  const loopd::SweepBend bend = loopd::SweepBend::from_poses(track(onset), stamp, kPeriod, 0.25);
  REQUIRE_FALSE(bend.empty());
  CHECK(bend.times().front() == Approx(-kPeriod));
  CHECK(bend.times().back() == 0.0);
  // B(t) = Screw(t / d)^-1 T(stamp)^-1 T(stamp + t): off the chord by up to an eighth of the sweep's 3 deg of turn.
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity(), delta = onset(0.0).inverse() * onset(kPeriod);
  for (const double t : {-0.075, -0.05, -0.025}) {
    const Eigen::Isometry3d expected = loopd::interpolate_screw(I, delta, t / kPeriod).inverse() * onset(kPeriod).inverse() * onset(kPeriod + t);
    CHECK(rotation_deg(expected.inverse() * bend.at(t)) < 1e-6);
    CHECK((expected.translation() - bend.at(t).translation()).norm() < 1e-6);
  }
  CHECK(bend.max_rotation_deg() > 0.3);
  CHECK(rotation_deg(bend.at(0.0)) < 1e-12);
  // Poses only at the stamps: no bend (10 Hz odometry).
  const std::vector<loopd::StampedPose> ends{{kUtime, onset(0.0), 0.0}, {stamp, onset(kPeriod), 0.0}};
  CHECK(loopd::SweepBend::from_poses(ends, stamp, kPeriod, 0.25).empty());
}

TEST_CASE("with a gyro a turn's onset inside the sweep is deskewed as the sensor turned, the increment from the scans", "[registration][imu]") {
  loopd::Town town = loopd::make_town(1);
  const Eigen::Isometry3d T0 = loopd::street_pose(town, 0, 0, 0, 25.0);
  const auto path = [](double t) { return onset_motion(t, 0.05); };  // the turn rate steps halfway through the current sweep
  const loopd::LidarModel model = loopd::lidar_model_hdl64();
  loopd::SensorEffects fx = loopd::SensorEffects::none();
  fx.motion_skew = true;
  fx.point_times = true;
  const loopd::PointCloud previous = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * path(t); }, kPeriod, fx, 1, 2);
  const loopd::PointCloud current = loopd::simulate_sweep(
      town, model, [&](double t) { return T0 * path(kPeriod + t); }, kPeriod, fx, 2, 2);
  const loopd::PointCloud still = loopd::simulate_scan(town, model, T0 * path(kPeriod), 2, 2);
  const Eigen::Isometry3d truth = path(kPeriod), odometry = noisy(truth);
  const loopd::SweepIncrement previous_sweep{path(-kPeriod).inverse() * path(0.0), kPeriod};

  // The gyro over both sweeps, dead-reckoned at the odometry's speed, as the engine hands it over.
  const std::vector<loopd::StampedPose> gyro =
      loopd::integrate_gyro(gyro_on(path, -kPeriod, kPeriod), Eigen::Matrix3d::Identity(), 0.05, odometry.translation() / kPeriod);
  loopd::SweepBends bends;
  const std::int64_t previous_stamp = kUtime, current_stamp = kUtime + 100000;
  bends.current = loopd::SweepBend::from_poses(gyro, current_stamp, kPeriod, 0.25);
  bends.previous = loopd::SweepBend::from_poses(gyro, previous_stamp, kPeriod, 0.25);
  bends.current_rotation = loopd::gyro_rotation(gyro, previous_stamp, current_stamp, 0.05);
  bends.previous_rotation = loopd::gyro_rotation(gyro, previous_stamp - 100000, previous_stamp, 0.05);
  REQUIRE(bends.current_rotation);
  REQUIRE(bends.previous_rotation);

  const loopd::SweepMotionResult shaped =
      loopd::estimate_sweep_motion(previous, current, kPeriod, odometry, loopd::SweepMotionConfig{}, previous_sweep);
  const loopd::SweepMotionResult bent =
      loopd::estimate_sweep_motion(previous, current, kPeriod, odometry, loopd::SweepMotionConfig{}, previous_sweep, bends);
  INFO(shaped.reason << " / " << bent.reason);
  REQUIRE(bent.refined);
  CHECK(bent.bent);
  CHECK_FALSE(bent.shape_refined);  // the gyro gives the shape
  const double rotation_error = rotation_deg(truth.inverse() * bent.T_previous_current);
  CAPTURE(rotation_error, rotation_deg(truth.inverse() * shaped.T_previous_current));
  CHECK(rotation_error < 0.05);

  // Deskewed on the scans' increment bent as the gyro turned (the path the engine hands to deskew()) the sweep lies
  // on the scan seen standing still at the stamp closer than with two turn rates refined against the previous sweep.
  std::vector<double> times;
  std::vector<Eigen::Isometry3d> poses;
  for (const double t : bends.current.times()) {
    times.push_back(t);
    poses.push_back(loopd::interpolate_screw(Eigen::Isometry3d::Identity(), bent.T_previous_current, 1.0 + t / kPeriod) * bends.current.at(t));
  }
  const double d_gyro = mean_distance_to_still(deskewed_on(current, times, poses), still);
  const double d_shape = shaped.shape_refined ? mean_distance_to_still(deskewed_on(current, shaped.knot_times, shaped.T_previous_knot), still)
                                              : mean_distance_to_still(deskewed_with(current, shaped.T_previous_current), still);
  const double d_truth = mean_distance_to_still(
      deskewed_on(current, {-0.1, -0.075, -0.05, -0.025, 0.0}, {path(0.0), path(0.025), path(0.05), path(0.075), path(0.1)}), still);
  CAPTURE(d_gyro, d_shape, d_truth);
  CHECK(d_gyro < d_shape);
  CHECK(d_gyro < d_truth + 0.003);
  WARN("turn onset with a gyro: increment rotation error " << rotation_error << " deg; deskewed " << d_gyro
                                                           << " m from the still scan (two turn rates: " << d_shape
                                                           << ", the true path at 40 Hz: " << d_truth << ")");
}
