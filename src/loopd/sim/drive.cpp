#include "loopd/sim/drive.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/mine.hpp"
#include "loopd/sim/route.hpp"
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

constexpr double kMineLaneLateral = 0.0;   ///< [m] the mine route drives on the roadway centre line
constexpr double kMineCornerRadius = 3.0;  ///< [m] its corners (junction chambers are ~7-12 m across)
/// [m/s] 18 km/h, a mine vehicle's pace in a roadway: 10 m/s round a 3 m corner would be 3.4 g, and its 190 deg/s
/// turn skews a sweep by 19 deg (at 5 m/s: 0.85 g, 9.5 deg).
constexpr double kMineSpeed = 5.0;

class DriveRng {
 public:
  explicit DriveRng(std::uint64_t seed) : state_(detail::mix64(seed ^ 0xD81FEull)) {}
  double uniform() { return detail::hash_uniform(detail::mix64(state_ += 0x9E3779B97F4A7C15ull)); }
  double gaussian() {
    const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::uint64_t state_;
};

/// Planar position, heading and visit label `s` [m] into a lap of `path` (any real number: laps repeat): the path
/// sample at or before it, linear between samples; the heading is a 1 m chord's around each sample, interpolated between
/// the samples as well (it stepped at each sample before: 0.3-0.6 deg every 5 cm in a corner, a turn no vehicle makes).
void planar_at(const std::vector<DrivePathPoint>& path, double lap_length, double route_distance, Eigen::Vector2d* p, double* yaw, int* visit) {
  const int lap = static_cast<int>(std::floor(route_distance / lap_length));
  const double s = route_distance - lap * lap_length;
  const auto after = std::upper_bound(path.begin(), path.end(), s, [](double v, const DrivePathPoint& q) { return v < q.s; });
  const std::size_t cursor = after == path.begin() ? 0 : static_cast<std::size_t>(after - path.begin()) - 1;
  const DrivePathPoint& a = path[cursor];
  const DrivePathPoint& b = path[(cursor + 1) % path.size()];
  const double seg = cursor + 1 < path.size() ? b.s - a.s : lap_length - a.s;
  const double alpha = seg > 1e-12 ? std::clamp((s - a.s) / seg, 0.0, 1.0) : 0.0;
  *p = a.p + alpha * (b.p - a.p);
  const std::size_t n = path.size();
  auto chord_yaw = [&](std::size_t c) {
    const Eigen::Vector2d t = path[(c + 11) % n].p - path[(c + n - 10) % n].p;
    return std::atan2(t.y(), t.x());
  };
  const double yaw_a = chord_yaw(cursor), yaw_b = chord_yaw((cursor + 1) % n);
  *yaw = yaw_a + alpha * std::remainder(yaw_b - yaw_a, 2.0 * kPi);
  if (visit) *visit = a.visit + kRouteVisitsPerLap * lap;
}

/// Ground-truth pose and visit label after `route_distance` of the drive (from d.start_offset into the lap).
Eigen::Isometry3d path_pose(const Drive& d, double route_distance, int* visit) {
  Eigen::Vector2d p;
  double yaw;
  planar_at(d.path, d.lap_length, route_distance + d.start_offset, &p, &yaw, visit);
  return ground_pose(d.town, p.x(), p.y(), yaw, d.config.sensor_height);
}

double lap_length_of(const std::vector<DrivePathPoint>& path) { return path.back().s + (path.front().p - path.back().p).norm(); }

/// Session K >= 2's start in its lap (DriveConfig): the first hashed offset whose start is > 50 m from session 1's
/// first pose or heads > 90 deg away from it.
double session_start_offset(const Drive& d) {
  const std::vector<DrivePathPoint> first = d.reversed ? build_route_path(d.town, d.config, false) : d.path;
  Eigen::Vector2d p1;
  double yaw1;
  planar_at(first, lap_length_of(first), 0.0, &p1, &yaw1, nullptr);
  const std::uint64_t h = detail::hash_combine(d.config.seed ^ 0x5E5510ull, static_cast<std::uint64_t>(d.config.session));
  double offset = 0.0;
  for (std::uint64_t attempt = 0; attempt < 64; ++attempt) {
    offset = d.lap_length * detail::hash_uniform(detail::hash_combine(h, attempt));
    Eigen::Vector2d p;
    double yaw;
    planar_at(d.path, d.lap_length, offset, &p, &yaw, nullptr);
    const double turn = std::abs(std::remainder(yaw - yaw1, 2.0 * kPi));
    if ((p - p1).norm() > 50.0 || turn > 0.5 * kPi) break;
  }
  return offset;
}

/// The odometry step of a ground-truth increment: systematic bias, random walk, white noise (x `m` in a degraded
/// stretch). Sets *injected to the random part (translation + 10 m * angles).
Eigen::Isometry3d noisy_step(const Eigen::Isometry3d& delta, double m, const DriveConfig& config, DriveRng* rng, double* injected) {
  const double dist = delta.translation().norm();
  const double yaw_noise = m * config.yaw_random_walk_deg * kRadPerDeg * rng->gaussian();
  const double yaw_err = config.heading_bias_deg_per_100m * kRadPerDeg * dist / 100.0 + yaw_noise;
  const Eigen::Vector3d t_noise(m * config.translation_noise * rng->gaussian(), m * config.translation_noise * rng->gaussian(),
                                0.3 * m * config.translation_noise * rng->gaussian());
  const double pitch = m * config.pitch_roll_noise_deg * kRadPerDeg * rng->gaussian();
  const double roll = m * config.pitch_roll_noise_deg * kRadPerDeg * rng->gaussian();
  Eigen::Isometry3d noisy = delta;
  noisy.translation() = (1.0 + config.scale_bias) * delta.translation() + t_noise;
  noisy.linear() = (Eigen::AngleAxisd(yaw_err, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix() *
                   delta.linear();
  *injected = t_noise.norm() + 10.0 * std::abs(yaw_noise) + 10.0 * std::hypot(pitch, roll);
  return noisy;
}

/// Odometry: ground-truth increments with systematic bias, random walk and degraded stretches; session 1 starts at the
/// ground truth, other sessions and the reset scan at identity.
void make_odometry(Drive* d) {
  const DriveConfig& config = d->config;
  const std::uint64_t seed = detail::hash_combine(config.seed, 0x0D0ull);
  DriveRng rng(config.session == 1 ? seed : detail::hash_combine(seed, static_cast<std::uint64_t>(config.session)));
  Eigen::Isometry3d T_odo = config.session == 1 ? d->scans[0].T_world_sensor : Eigen::Isometry3d::Identity();
  const int reset = config.odometry_reset_at.value_or(-1);
  int burst_left = 0;
  for (int i = 0; i < config.num_scans; ++i) {
    DriveScan& sc = d->scans[static_cast<std::size_t>(i)];
    sc.odometry.utime = sc.utime;
    sc.odometry_segment = reset >= 1 && i >= reset ? 1 : 0;
    if (i == 0) {
      sc.odometry.T_world_sensor = T_odo;
      sc.odometry.residual = config.base_residual;
      continue;
    }
    const Eigen::Isometry3d delta = d->scans[static_cast<std::size_t>(i - 1)].T_world_sensor.inverse() * sc.T_world_sensor;
    if (burst_left > 0) {
      --burst_left;
      sc.degraded = true;
    } else if (rng.uniform() < config.burst_probability) {
      burst_left = config.burst_length - 1;
      sc.degraded = config.burst_length > 0;
    }
    T_odo = T_odo * noisy_step(delta, sc.degraded ? config.burst_factor : 1.0, config, &rng, &sc.injected_error);
    if (i == reset) T_odo = Eigen::Isometry3d::Identity();  // the odometry process restarted
    sc.odometry.T_world_sensor = T_odo;
    // What a scan matcher would report: a floor plus the random error of this step.
    sc.odometry.residual = config.base_residual * (0.8 + 0.4 * rng.uniform()) + sc.injected_error;
  }
}

/// The mine's roadways are 4-6 m wide: its drive keeps to the centre line, turns with 3 m corners and goes at 5 m/s,
/// where the config still holds the town's defaults (lane_lateral -2 m, corner_radius 9 m, speed 10 m/s); values set to
/// anything else are kept.
DriveConfig route_defaults(const DriveConfig& config) {
  DriveConfig c = config;
  const DriveConfig town;
  if (config.route == "mine") {
    if (config.lane_lateral == town.lane_lateral) c.lane_lateral = kMineLaneLateral;
    if (config.corner_radius == town.corner_radius) c.corner_radius = kMineCornerRadius;
    if (config.speed == town.speed) c.speed = kMineSpeed;
  }
  return c;
}

}  // namespace

std::optional<std::string> DriveConfig::validate() const {
  if (!lidar_model_from_name(sensor)) return "unknown sensor '" + sensor + "'";
  if (num_scans < 1) return std::string("num_scans must be >= 1");
  if (!is_route_name(route)) return "unknown route '" + route + "' (town, block, ring, mine)";
  if (session < 1 || session > 1000) return "session must be in [1, 1000], got " + std::to_string(session);
  if (odometry_reset_at && (*odometry_reset_at < 1 || *odometry_reset_at >= num_scans))
    return "odometry_reset_at (the scan where odometry restarts) must be in [1, num_scans = " + std::to_string(num_scans) + "), got " +
           std::to_string(*odometry_reset_at);
  if (!(speed > 0.0 && speed < 60.0)) return std::string("speed must be in (0, 60) m/s");
  if (!(rate_hz > 0.0 && rate_hz <= 100.0)) return std::string("rate_hz must be in (0, 100]");
  if (!(sensor_height > 0.2)) return std::string("sensor_height must be > 0.2 m");
  if (!(corner_radius >= 3.0 && corner_radius <= 15.0)) return std::string("corner_radius must be in [3, 15] m");
  if (std::abs(lane_lateral) > 5.0 || std::abs(lane_lateral + lane_offset) > 5.5)
    return std::string("lane positions must stay on the road (|lateral| <= 5 m)");
  if (scale_bias <= -0.5 || scale_bias >= 0.5) return std::string("scale_bias must be in (-0.5, 0.5)");
  if (yaw_random_walk_deg < 0 || translation_noise < 0 || pitch_roll_noise_deg < 0) return std::string("noise sigmas must be >= 0");
  if (burst_probability < 0 || burst_probability > 1 || burst_length < 0 || burst_factor < 1) return std::string("bad burst settings");
  if (base_residual < 0) return std::string("base_residual must be >= 0");
  if (auto err = effects.validate()) return "effects: " + *err;
  return std::nullopt;
}

std::uint64_t Drive::scan_seed(int i) const {
  const std::uint64_t h = detail::hash_combine(config.seed ^ 0x5CA9ull, static_cast<std::uint64_t>(i));
  return config.session == 1 ? h : detail::hash_combine(h, std::uint64_t{0x5E5510} + static_cast<std::uint64_t>(config.session));
}

PointCloud Drive::simulate(int i, int num_threads) const {
  if (i < 0 || i >= static_cast<int>(scans.size())) return PointCloud{};
  const DriveScan& s = scans[static_cast<std::size_t>(i)];
  const SensorPoseAt pose_at = [this, &s](double t) {
    return t == 0.0 ? s.T_world_sensor : pose_at_distance(s.route_distance + config.speed * t);  // constant speed
  };
  return simulate_sweep(town, model, pose_at, 1.0 / config.rate_hz, config.effects, scan_seed(i), num_threads, s.visit + car_visit_offset);
}

Eigen::Isometry3d Drive::pose_at_distance(double route_distance) const {
  if (path.empty() || !(lap_length > 0.0)) return Eigen::Isometry3d::Identity();
  return path_pose(*this, route_distance, nullptr);
}

int Drive::num_visits() const {
  int v = -1;
  for (const auto& s : scans) v = std::max(v, s.visit);
  return v + 1;
}

int Drive::count_revisits(double radius, int min_gap) const {
  int count = 0;
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const Eigen::Vector3d pi = scans[i].T_world_sensor.translation();
    for (std::size_t j = 0; j + static_cast<std::size_t>(std::max(min_gap, 1)) <= i; ++j) {
      if ((scans[j].T_world_sensor.translation() - pi).squaredNorm() < r2) {
        ++count;
        break;
      }
    }
  }
  return count;
}

Drive make_drive(const DriveConfig& config) {
  Drive d;
  d.config = config;
  if (auto err = config.validate()) {
    d.error = *err;
    return d;
  }
  d.config = route_defaults(config);
  const DriveConfig& c = d.config;
  d.model = *lidar_model_from_name(c.sensor);
  d.town = c.route == "mine" ? make_mine(c.seed) : make_town(c.seed);
  d.reversed = c.session % 2 == 0;
  d.path = build_route_path(d.town, c, d.reversed);
  d.lap_length = lap_length_of(d.path);
  if (c.session >= 2) {
    d.start_offset = session_start_offset(d);
    d.car_visit_offset = (c.session - 1) << 20;
  }
  const double step = c.speed / c.rate_hz;
  const std::int64_t start_utime = c.start_utime + (c.same_day ? 0 : std::int64_t{86400000000} * (c.session - 1));

  // Ground truth at each scan's stamp.
  d.scans.resize(static_cast<std::size_t>(c.num_scans));
  for (int i = 0; i < c.num_scans; ++i) {
    DriveScan& sc = d.scans[static_cast<std::size_t>(i)];
    sc.index = i;
    sc.utime = start_utime + static_cast<std::int64_t>(std::llround(1e6 * i / c.rate_hz));
    sc.route_distance = step * i;
    sc.T_world_sensor = path_pose(d, sc.route_distance, &sc.visit);
  }
  make_odometry(&d);
  return d;
}

}  // namespace loopd
