#include "loopd/sim/gyro_sim.hpp"

#include <cmath>

#include "loopd/base/angles.hpp"
#include "loopd/sim/sample_grid.hpp"

namespace loopd {
namespace {

/// A standard normal number from two hashes of `key` (Box-Muller).
double gaussian(std::uint64_t key) {
  const double u1 = std::max(detail::hash_uniform(detail::mix64(key)), 1e-300);
  const double u2 = detail::hash_uniform(detail::mix64(key ^ 0x5851F42D4C957F2Dull));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

}  // namespace

std::optional<std::string> GyroSimConfig::validate() const {
  if (!(rate_hz >= 0.0 && rate_hz <= 10000.0)) return "gyro rate must be in [0, 10000] Hz";
  if (!(noise_deg_s >= 0.0) || !(bias_deg_s >= 0.0)) return "gyro noise and bias must be >= 0";
  return std::nullopt;
}

std::vector<ImuSample> simulate_gyro(const Drive& drive, const GyroSimConfig& config, int scan_index) {
  std::vector<ImuSample> out;
  if (!(config.rate_hz > 0.0) || scan_index < 0 || scan_index >= static_cast<int>(drive.scans.size())) return out;
  const DriveScan& scan = drive.scans[static_cast<std::size_t>(scan_index)];
  const std::int64_t sweep_us = std::llround(1e6 / drive.config.rate_hz);
  const std::int64_t begin = scan_index > 0 ? drive.scans[static_cast<std::size_t>(scan_index - 1)].utime : scan.utime - sweep_us;
  const double h = 1.0 / config.rate_hz;
  const std::uint64_t seed =
      detail::hash_combine(detail::hash_combine(drive.config.seed, 0x6A1ull), static_cast<std::uint64_t>(drive.config.session));
  Eigen::Vector3d bias;
  for (int a = 0; a < 3; ++a)
    bias[a] = (2.0 * detail::hash_uniform(detail::mix64(seed + static_cast<std::uint64_t>(a))) - 1.0) * config.bias_deg_s * kRadPerDeg;
  for (const auto [k, utime] : grid_times(drive.config.start_utime, config.rate_hz, begin, scan.utime)) {
    const double t = static_cast<double>(utime - scan.utime) * 1e-6;  // [s] relative to the scan's stamp
    const Eigen::Isometry3d a = drive.pose_at_distance(scan.route_distance + drive.config.speed * (t - h));
    const Eigen::Isometry3d b = drive.pose_at_distance(scan.route_distance + drive.config.speed * t);
    const Eigen::AngleAxisd turn(a.linear().transpose() * b.linear());
    ImuSample s;
    s.utime = utime;
    s.angular_velocity = turn.axis() * turn.angle() / h + bias;
    const std::uint64_t key = detail::hash_combine(seed, static_cast<std::uint64_t>(k));
    for (int ax = 0; ax < 3; ++ax)
      s.angular_velocity[ax] += config.noise_deg_s * kRadPerDeg * gaussian(key + static_cast<std::uint64_t>(ax) * std::uint64_t{0x9E37});
    out.push_back(s);
  }
  return out;
}

}  // namespace loopd
