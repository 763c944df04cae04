#include "loopd/sim/drive.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/sim/lidar_sim.hpp"

namespace loopd {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(detail::mix64(seed ^ 0xD81FEull)) {}
  double uniform() { return detail::hash_uniform(detail::mix64(state_ += 0x9E3779B97F4A7C15ull)); }
  double gaussian() {
    const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::uint64_t state_;
};

struct Waypoint {
  int i, j;
  int visit;         ///< visit label of the edge that leaves this waypoint
  bool lane_offset;  ///< the first half of the edge leaving this waypoint is driven with the lane offset
};

/// One lap of the route (cyclic: the last edge returns to the first waypoint).
std::vector<Waypoint> route_waypoints(const std::string& route) {
  std::vector<Waypoint> w;
  auto add = [&](int i, int j, int v, bool off = false) { w.push_back({i, j, v, off}); };
  if (route == "block") {
    // Three laps of block (0..1, 0..1), counter-clockwise; the third starts with the lane offset.
    for (int v = 0; v < 3; ++v) {
      add(0, 0, v, v == 2);
      add(1, 0, v);
      add(1, 1, v);
      add(0, 1, v);
    }
    return w;
  }
  // Visit 0: short loop around block (0..1, 0..1), counter-clockwise.
  add(0, 0, 0);
  add(1, 0, 0);
  add(1, 1, 0);
  add(0, 1, 0);
  // Visit 1: long loop around (0..2, 0..2), counter-clockwise: (0,0)->(1,0) again in the same direction (first half
  // 3 m to the left = lane offset), (0,1)->(0,0) again in the same direction.
  add(0, 0, 1, true);
  add(1, 0, 1);
  add(2, 0, 1);
  add(2, 1, 1);
  add(2, 2, 1);
  add(1, 2, 1);
  add(0, 2, 1);
  add(0, 1, 1);
  // Visit 2: turn around through (0,-1), (1,-1), then block (0..1, 0..1) clockwise (opposite direction), back via (1,-1).
  add(0, 0, 2);
  add(0, -1, 2);
  add(1, -1, 2);
  add(1, 0, 2);
  add(0, 0, 2);
  add(0, 1, 2);
  add(1, 1, 2);
  add(1, 0, 2);
  add(1, -1, 2);
  add(0, -1, 2);
  return w;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

/// Dense samples of one lap of the driven path (lane offset applied), arc length filled.
std::vector<DrivePathPoint> build_path(const Town& town, const DriveConfig& c) {
  const auto w = route_waypoints(c.route);
  const int K = static_cast<int>(w.size());
  std::vector<Eigen::Vector2d> P(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) P[static_cast<std::size_t>(k)] = town.node(w[static_cast<std::size_t>(k)].i, w[static_cast<std::size_t>(k)].j);
  auto at = [&](int k) -> const Eigen::Vector2d& { return P[static_cast<std::size_t>(((k % K) + K) % K)]; };
  const double R = c.corner_radius;
  // Corner entry/exit points.
  std::vector<Eigen::Vector2d> A(static_cast<std::size_t>(K)), B(static_cast<std::size_t>(K));
  std::vector<bool> turn(static_cast<std::size_t>(K));
  for (int k = 0; k < K; ++k) {
    const Eigen::Vector2d u = (at(k) - at(k - 1)).normalized(), v = (at(k + 1) - at(k)).normalized();
    turn[static_cast<std::size_t>(k)] = u.dot(v) < 0.99;
    A[static_cast<std::size_t>(k)] = turn[static_cast<std::size_t>(k)] ? Eigen::Vector2d(at(k) - u * R) : at(k);
    B[static_cast<std::size_t>(k)] = turn[static_cast<std::size_t>(k)] ? Eigen::Vector2d(at(k) + v * R) : at(k);
  }
  // Centre-line samples with visit labels and lateral offsets.
  struct Raw {
    Eigen::Vector2d c;
    int visit;
    double lateral;
  };
  std::vector<Raw> raw;
  const double ds = 0.05;
  for (int k = 0; k < K; ++k) {
    const Waypoint& wp = w[static_cast<std::size_t>(k)];
    const Eigen::Vector2d s0 = B[static_cast<std::size_t>(k)], s1 = A[static_cast<std::size_t>((k + 1) % K)];
    const double L = (s1 - s0).norm();
    const int n = std::max(1, static_cast<int>(L / ds));
    for (int q = 0; q < n; ++q) {
      const double a = static_cast<double>(q) / n;
      const double along = a * L;
      double lateral = c.lane_lateral;
      if (wp.lane_offset) {
        // Ramp into the offset lane over 10 m, hold to mid-edge, ramp back over 15 m.
        const double up = smoothstep(along / 10.0), down = 1.0 - smoothstep((along - 0.5 * L) / 15.0);
        lateral += c.lane_offset * std::min(up, down);
      }
      raw.push_back({s0 + a * (s1 - s0), wp.visit, lateral});
    }
    const int kn = (k + 1) % K;
    if (turn[static_cast<std::size_t>(kn)]) {
      const Eigen::Vector2d a0 = A[static_cast<std::size_t>(kn)], p = at(kn), b0 = B[static_cast<std::size_t>(kn)];
      const int m = std::max(4, static_cast<int>(1.6 * R / ds));
      for (int q = 0; q < m; ++q) {
        const double t = static_cast<double>(q) / m;
        const Eigen::Vector2d cq = (1 - t) * (1 - t) * a0 + 2 * t * (1 - t) * p + t * t * b0;  // quadratic Bezier corner
        raw.push_back({cq, wp.visit, c.lane_lateral});
      }
    }
  }
  // Offset along the left normal of the centre line, then arc length.
  const std::size_t N = raw.size();
  std::vector<DrivePathPoint> out(N);
  for (std::size_t q = 0; q < N; ++q) {
    const Eigen::Vector2d d = raw[(q + 1) % N].c - raw[(q + N - 1) % N].c;
    const Eigen::Vector2d t = d.norm() > 1e-9 ? Eigen::Vector2d(d.normalized()) : Eigen::Vector2d(1, 0);
    const Eigen::Vector2d left(-t.y(), t.x());
    out[q].p = raw[q].c + raw[q].lateral * left;
    out[q].visit = raw[q].visit;
    out[q].s = q == 0 ? 0.0 : out[q - 1].s + (out[q].p - out[q - 1].p).norm();
  }
  return out;
}

/// Ground-truth pose and visit label after `route_distance` of the route: the path sample at or before it (its lap
/// repeating), linear between samples, heading from a 1 m chord around the sample (smooth through corners).
Eigen::Isometry3d path_pose(const Drive& d, double route_distance, int* visit) {
  const auto& path = d.path;
  const int lap = static_cast<int>(std::floor(route_distance / d.lap_length));
  const double s = route_distance - lap * d.lap_length;
  const auto after = std::upper_bound(path.begin(), path.end(), s, [](double v, const DrivePathPoint& q) { return v < q.s; });
  const std::size_t cursor = after == path.begin() ? 0 : static_cast<std::size_t>(after - path.begin()) - 1;
  const DrivePathPoint& a = path[cursor];
  const DrivePathPoint& b = path[(cursor + 1) % path.size()];
  const double seg = cursor + 1 < path.size() ? b.s - a.s : d.lap_length - a.s;
  const double alpha = seg > 1e-12 ? std::clamp((s - a.s) / seg, 0.0, 1.0) : 0.0;
  const Eigen::Vector2d p = a.p + alpha * (b.p - a.p);
  const std::size_t n = path.size();
  const std::size_t back = (cursor + n - 10) % n, fwd = (cursor + 11) % n;
  const Eigen::Vector2d t = path[fwd].p - path[back].p;
  const double yaw = std::atan2(t.y(), t.x());
  constexpr int kVisitsPerLap = 3;
  if (visit) *visit = a.visit + kVisitsPerLap * lap;
  return ground_pose(d.town, p.x(), p.y(), yaw, d.config.sensor_height);
}

}  // namespace

std::optional<std::string> DriveConfig::validate() const {
  if (!lidar_model_from_name(sensor)) return "unknown sensor '" + sensor + "'";
  if (num_scans < 1) return std::string("num_scans must be >= 1");
  if (route != "town" && route != "block") return "unknown route '" + route + "' (town, block)";
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

std::uint64_t Drive::scan_seed(int i) const { return detail::hash_combine(config.seed ^ 0x5CA9ull, static_cast<std::uint64_t>(i)); }

PointCloud Drive::simulate(int i, int num_threads) const {
  if (i < 0 || i >= static_cast<int>(scans.size())) return PointCloud{};
  const DriveScan& s = scans[static_cast<std::size_t>(i)];
  const SensorPoseAt pose_at = [this, &s](double t) {
    return t == 0.0 ? s.T_world_sensor : pose_at_distance(s.route_distance + config.speed * t);  // constant speed
  };
  return simulate_sweep(town, model, pose_at, 1.0 / config.rate_hz, config.effects, scan_seed(i), num_threads, s.visit);
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
  d.model = *lidar_model_from_name(config.sensor);
  d.town = make_town(config.seed);
  d.path = build_path(d.town, config);
  d.lap_length = d.path.back().s + (d.path.front().p - d.path.back().p).norm();
  const double step = config.speed / config.rate_hz;

  // Ground truth at each scan's stamp.
  d.scans.resize(static_cast<std::size_t>(config.num_scans));
  for (int i = 0; i < config.num_scans; ++i) {
    DriveScan& sc = d.scans[static_cast<std::size_t>(i)];
    sc.index = i;
    sc.utime = config.start_utime + static_cast<std::int64_t>(std::llround(1e6 * i / config.rate_hz));
    sc.route_distance = step * i;
    sc.T_world_sensor = path_pose(d, sc.route_distance, &sc.visit);
  }

  // Odometry: ground-truth increments with systematic bias, random walk and degraded stretches.
  Rng rng(detail::hash_combine(config.seed, 0x0D0ull));
  Eigen::Isometry3d T_odo = d.scans[0].T_world_sensor;
  int burst_left = 0;
  for (int i = 0; i < config.num_scans; ++i) {
    DriveScan& sc = d.scans[static_cast<std::size_t>(i)];
    if (i == 0) {
      sc.odometry.utime = sc.utime;
      sc.odometry.T_world_sensor = T_odo;
      sc.odometry.residual = config.base_residual;
      continue;
    }
    const Eigen::Isometry3d delta = d.scans[static_cast<std::size_t>(i - 1)].T_world_sensor.inverse() * sc.T_world_sensor;
    if (burst_left > 0) {
      --burst_left;
      sc.degraded = true;
    } else if (rng.uniform() < config.burst_probability) {
      burst_left = config.burst_length - 1;
      sc.degraded = config.burst_length > 0;
    }
    const double m = sc.degraded ? config.burst_factor : 1.0;
    const double dist = delta.translation().norm();
    const double yaw_noise = m * config.yaw_random_walk_deg * kDeg * rng.gaussian();
    const double yaw_err = config.heading_bias_deg_per_100m * kDeg * dist / 100.0 + yaw_noise;
    const Eigen::Vector3d t_noise(m * config.translation_noise * rng.gaussian(), m * config.translation_noise * rng.gaussian(),
                                  0.3 * m * config.translation_noise * rng.gaussian());
    const double pitch = m * config.pitch_roll_noise_deg * kDeg * rng.gaussian();
    const double roll = m * config.pitch_roll_noise_deg * kDeg * rng.gaussian();
    Eigen::Isometry3d noisy = delta;
    noisy.translation() = (1.0 + config.scale_bias) * delta.translation() + t_noise;
    noisy.linear() = (Eigen::AngleAxisd(yaw_err, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                      Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix() *
                     delta.linear();
    T_odo = T_odo * noisy;
    sc.injected_error = t_noise.norm() + 10.0 * std::abs(yaw_noise) + 10.0 * std::hypot(pitch, roll);
    sc.odometry.utime = sc.utime;
    sc.odometry.T_world_sensor = T_odo;
    // What a scan matcher would report: a floor plus the random error of this step.
    sc.odometry.residual = config.base_residual * (0.8 + 0.4 * rng.uniform()) + sc.injected_error;
  }
  return d;
}

}  // namespace loopd
