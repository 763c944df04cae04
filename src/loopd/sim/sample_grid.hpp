#pragma once
/// @file The times of a stream sampled on a fixed grid from a drive's first scan (the gyro, odometry between scans).
#include <cmath>
#include <cstdint>
#include <vector>

namespace loopd {

/// @brief A grid time: its index k and origin + k / rate_hz [us, rounded].
struct GridTime {
  std::int64_t k = 0, utime = 0;
};

/// @brief Every grid time with after < utime <= until.
inline std::vector<GridTime> grid_times(std::int64_t origin, double rate_hz, std::int64_t after, std::int64_t until) {
  std::vector<GridTime> out;
  const double period_us = 1e6 / rate_hz;
  for (auto k = static_cast<std::int64_t>(std::floor(static_cast<double>(after - origin) / period_us)) + 1;; ++k) {
    const std::int64_t utime = origin + std::llround(static_cast<double>(k) * period_us);
    if (utime > until) break;
    if (utime > after) out.push_back({k, utime});
  }
  return out;
}

}  // namespace loopd
