#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace loopd {

/// @brief A lidar sweep in the sensor frame. Attributes are either empty or sized like `points`.
struct PointCloud {
  std::vector<Eigen::Vector3f> points;  ///< [m]
  std::vector<float> intensity;         ///< optional, sensor units
  std::vector<std::uint16_t> ring;      ///< optional laser ring index (0 = lowest beam)
  int num_rings = 0;                    ///< 0 when unknown
  std::vector<float> time;              ///< optional [s] measurement time of each point relative to the scan's stamp

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_rings() const { return num_rings > 0 && ring.size() == points.size(); }
  bool has_intensity() const { return intensity.size() == points.size(); }
  bool has_time() const { return !points.empty() && time.size() == points.size(); }
  void reserve(std::size_t n) {
    points.reserve(n);
    intensity.reserve(n);
  }
};

}  // namespace loopd
