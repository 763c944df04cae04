// Range-image segmentation (Vlaminck 2019, Sec. 4.2.1): the scan is projected on a rings x azimuth grid so that
// neighbouring points are found by adjacency, clusters grow over 4-neighbours with two comparators (Euclidean 3D
// distance and surface-normal deviation), and each cluster is tested for a plane (PCA) whose 2D convex hull is kept
// to pick wide coplanar 4PCS bases. The steps live in range_image.cpp, region_growing.cpp and cluster_fit.cpp.
#include "loopd/segmentation/segmentation.hpp"

#include "loopd/base/stopwatch.hpp"
#include "loopd/segmentation/segmentation_internal.hpp"

namespace loopd {

std::optional<std::string> SegmentationConfig::validate() const {
  if (max_neighbor_distance <= 0) return "max_neighbor_distance must be > 0";
  if (distance_range_scale < 0) return "distance_range_scale must be >= 0";
  if (max_normal_angle_deg <= 0 || max_normal_angle_deg >= 90) return "max_normal_angle_deg must be in (0, 90)";
  if (min_cluster_points < 3) return "min_cluster_points must be >= 3";
  if (plane_rms_tolerance <= 0) return "plane_rms_tolerance must be > 0";
  if (keep_voxel_size <= 0) return "keep_voxel_size must be > 0";
  if (max_kept_points_per_cluster < 1) return "max_kept_points_per_cluster must be >= 1";
  if (max_hull_points < 4) return "max_hull_points must be >= 4";
  if (max_clusters < 1) return "max_clusters must be >= 1";
  if (min_range < 0 || max_range <= min_range) return "need 0 <= min_range < max_range";
  if (azimuth_columns < 0) return "azimuth_columns must be >= 0";
  if (elevation_bins < 2) return "elevation_bins must be >= 2";
  return std::nullopt;
}

std::size_t Segmentation::bytes() const {
  std::size_t b = sizeof(Segmentation) + error.capacity() + clusters.capacity() * sizeof(Cluster);
  for (const auto& c : clusters) b += (c.points.capacity() + c.hull.capacity()) * sizeof(Eigen::Vector3f);
  return b;
}

int Segmentation::num_planar() const {
  int n = 0;
  for (const auto& c : clusters) n += c.planar ? 1 : 0;
  return n;
}

Segmentation segment(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& config, std::vector<Eigen::Vector3f>* point_normals) {
  Stopwatch sw;
  Segmentation out;
  if (point_normals) point_normals->assign(scan.points.size(), Eigen::Vector3f::Zero());
  if (auto err = config.validate()) {
    out.error = "invalid SegmentationConfig: " + *err;
    return out;
  }
  if (scan.points.size() < static_cast<std::size_t>(config.min_cluster_points)) {
    out.error = "too few points to segment";
    out.ms = sw.ms();
    return out;
  }
  // The scan on its range image, with a surface normal per pixel.
  detail::RangeImage img;
  if (auto error = detail::build_range_image(scan, model, config, &img)) {
    out.error = *error;
    out.ms = sw.ms();
    return out;
  }
  detail::compute_normals(config, &img);
  if (point_normals) {
    for (std::size_t k = 0; k < img.index.size(); ++k)
      if (img.index[k] >= 0) (*point_normals)[detail::to_index(img.index[k])] = img.normal[k];
  }

  // Region growing over 4-neighbours (holes of one pixel are bridged) with the two comparators of Sec. 4.2.1.
  const detail::RawClusters raw = detail::grow_regions(img, config);

  // Largest clusters first (ties by first pixel: deterministic); per cluster the PCA plane, its hull, kept members.
  detail::ClusterScratch scratch;
  for (int id : detail::largest_clusters(raw, config)) out.clusters.push_back(detail::fit_cluster(img, raw.members(id), config, &scratch));
  out.ms = sw.ms();
  return out;
}

}  // namespace loopd
