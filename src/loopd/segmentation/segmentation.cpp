#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

std::optional<std::string> SegmentationConfig::validate() const {
  if (max_neighbor_distance <= 0) return "max_neighbor_distance must be > 0";
  if (max_normal_angle_deg <= 0 || max_normal_angle_deg >= 90) return "max_normal_angle_deg must be in (0, 90)";
  if (min_cluster_points < 3) return "min_cluster_points must be >= 3";
  if (plane_rms_tolerance <= 0) return "plane_rms_tolerance must be > 0";
  if (keep_voxel_size <= 0) return "keep_voxel_size must be > 0";
  if (min_range < 0 || max_range <= min_range) return "need 0 <= min_range < max_range";
  if (azimuth_columns < 0) return "azimuth_columns must be >= 0";
  if (elevation_bins < 2) return "elevation_bins must be >= 2";
  return std::nullopt;
}

std::size_t Segmentation::bytes() const {
  std::size_t b = sizeof(Segmentation) + error.capacity();
  for (const auto& c : clusters) b += sizeof(Cluster) + (c.points.capacity() + c.hull.capacity()) * sizeof(Eigen::Vector3f);
  return b;
}

int Segmentation::num_planar() const {
  int n = 0;
  for (const auto& c : clusters) n += c.planar ? 1 : 0;
  return n;
}

Segmentation segment(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& config) {
  (void)scan;
  (void)model;
  Segmentation out;
  if (auto err = config.validate()) out.error = *err;
  else out.error = "not implemented yet";
  return out;
}

}  // namespace loopd
