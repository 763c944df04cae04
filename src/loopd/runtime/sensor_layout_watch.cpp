#include "loopd/runtime/sensor_layout_watch.hpp"

#include <cmath>

namespace loopd {

bool SensorLayoutWatch::on_scan(std::int64_t num_points, int num_rings) {
  const double points = static_cast<double>(num_points);
  if (!known_) {
    known_ = true;
    rings_ = num_rings;
    typical_points_ = points;
    return false;
  }
  const bool odd = num_rings != rings_ || std::abs(points - typical_points_) > config_.point_band * typical_points_;
  if (!odd) {
    odd_in_a_row_ = 0;
    typical_points_ += 0.05 * (points - typical_points_);  // slow drift (scenes change the point count a little)
    return false;
  }
  // An odd scan: the new layout must hold for `confirm` scans, each like the first odd one.
  if (odd_in_a_row_ > 0 && (num_rings != odd_rings_ || std::abs(points - odd_points_) > config_.point_band * odd_points_)) odd_in_a_row_ = 0;
  if (odd_in_a_row_ == 0) {
    odd_rings_ = num_rings;
    odd_points_ = points;
  }
  if (++odd_in_a_row_ < config_.confirm) return false;
  odd_in_a_row_ = 0;
  rings_ = odd_rings_;
  typical_points_ = points;
  ++changes_;
  return true;
}

}  // namespace loopd
