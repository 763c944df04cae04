#include "loopd/sim/scan_pattern.hpp"

#include <cmath>

#include "loopd/sim/town.hpp"
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

// Incommensurate rates [Hz]: the rosette's two prisms; the MID-360-like elevation sweep.
constexpr double kPrismA = 173.137, kPrismB = -117.911, kElevationSweep = 1234.567;

Eigen::Vector3d direction(double azimuth, double elevation) {
  return {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
}

/// Triangle wave in [0, 1] of phase x (period 1).
double triangle(double x) {
  const double f = x - std::floor(x);
  return f < 0.5 ? 2.0 * f : 2.0 * (1.0 - f);
}

}  // namespace

std::vector<PatternRay> pattern_rays(const LidarModel& m, double period, std::uint64_t seed) {
  std::vector<PatternRay> rays;
  if (m.pattern == LidarModel::ScanPattern::kSpinning || m.num_rings <= 0 || m.azimuth_steps <= 0 || m.vertical_angles_deg.size() != 2) return rays;
  const int lasers = m.num_rings, steps = m.azimuth_steps;
  const double dt = (period > 0.0 ? period : 0.1) / steps;
  const double t0 = 1000.0 * detail::hash_uniform(detail::mix64(seed ^ 0x5CA9ull));  // where in the endless pattern
  const double el_lo = m.vertical_angles_deg[0] * kRadPerDeg, el_hi = m.vertical_angles_deg[1] * kRadPerDeg;
  rays.reserve(static_cast<std::size_t>(lasers) * static_cast<std::size_t>(steps));
  for (int k = 0; k < steps; ++k) {
    const double t = t0 + k * dt;
    const float time = static_cast<float>(-(steps - 1 - k) * dt);
    for (int j = 0; j < lasers; ++j) {
      PatternRay ray;
      ray.time = time;
      if (m.pattern == LidarModel::ScanPattern::kRosette) {
        const double a = 2.0 * kPi * kPrismA * t, b = 2.0 * kPi * kPrismB * t;
        const double u = 0.5 * (std::cos(a) + std::cos(b)), v = 0.5 * (std::sin(a) + std::sin(b));  // within the unit disk
        const double offset = (j - 0.5 * (lasers - 1)) * 1.5 * kRadPerDeg;
        const double az = 0.5 * m.horizontal_fov_deg * kRadPerDeg * u + offset;
        const double el = 0.5 * (el_lo + el_hi) + 0.5 * (el_hi - el_lo) * v;
        ray.direction = direction(az, el);
      } else {
        const double az = 2.0 * kPi * (static_cast<double>(k) / steps + 0.25 * j) + 2.0 * kPi * detail::hash_uniform(seed);
        const double el = el_lo + (el_hi - el_lo) * triangle(kElevationSweep * t + 0.25 * j);
        ray.direction = direction(az, el);
      }
      rays.push_back(ray);
    }
  }
  return rays;
}

}  // namespace loopd
