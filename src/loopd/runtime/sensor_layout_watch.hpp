#pragma once
#include <cstdint>

namespace loopd {

/// @brief Notices when the sensor behind the scan channel changes (another lidar plugged in, a reconfigured
///        resolution): the ring count changes, or the point count leaves its usual band for `confirm` scans in a row.
///        Single odd scans (a blocked sensor, a partial sweep) are not changes.
class SensorLayoutWatch {
 public:
  struct Config {
    double point_band = 0.35;  ///< relative change of the point count that counts
    int confirm = 5;           ///< consecutive scans that confirm a change
  };
  SensorLayoutWatch() = default;
  explicit SensorLayoutWatch(const Config& config) : config_(config) {}

  /// @brief One received scan; true when it confirms a change of layout.
  bool on_scan(std::int64_t num_points, int num_rings);
  std::int64_t changes() const { return changes_; }
  int num_rings() const { return rings_; }
  double typical_points() const { return typical_points_; }

 private:
  Config config_;
  bool known_ = false;
  int rings_ = 0;
  double typical_points_ = 0.0;
  int odd_in_a_row_ = 0;
  int odd_rings_ = 0;
  double odd_points_ = 0.0;
  std::int64_t changes_ = 0;
};

}  // namespace loopd
