#pragma once
// Private to loopd_segmentation: the steps of segment() (Vlaminck 2019, Sec. 4.2.1), one file each:
// range_image.cpp (projection on the rings x azimuth grid, surface normals), region_growing.cpp (clusters over
// 4-neighbours with the two comparators), cluster_fit.cpp (PCA plane, 2D convex hull, downsampled members).
#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/segmentation/segmentation.hpp"
#include "loopd/base/angles.hpp"

namespace loopd {

struct LidarModel;  // loopd/base/lidar_model.hpp

namespace detail {

/// @brief Vector index of an int index (pixels, members and hull vertices are ints throughout the segmentation).
inline std::size_t to_index(int i) { return static_cast<std::size_t>(i); }

/// @brief Flat index of pixel (r, c), computed in std::size_t.
inline std::size_t pixel_index(int r, int c, int cols) { return to_index(r) * to_index(cols) + to_index(c); }

/// @brief Column c wrapped around the 360-degree image (valid for -cols <= c < 2 cols).
inline int wrap(int c, int cols) { return c < 0 ? c + cols : (c >= cols ? c - cols : c); }

/// @brief Allowed distance between neighbouring pixels [m]; grows with range (the beams diverge).
inline float neighbor_threshold(const SegmentationConfig& cfg, float range) {
  return static_cast<float>(std::max(cfg.max_neighbor_distance, cfg.distance_range_scale * range));
}

/// @brief The scan projected on a rings x azimuth grid: neighbours are found by adjacency.
struct RangeImage {
  int rows = 0, cols = 0;
  std::vector<int> index;               ///< point index per pixel, -1 empty
  std::vector<float> range;             ///< [m] per pixel
  std::vector<Eigen::Vector3f> xyz;     ///< point per pixel (copied: neighbour lookups stay local in memory)
  std::vector<Eigen::Vector3f> normal;  ///< unit normal per pixel, zero when unknown
};

/// @brief Projects the scan (nearest return per pixel) into `img`; the reason when no rings can be derived.
std::optional<std::string> build_range_image(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& cfg, RangeImage* img);

/// @brief Fills img->normal: cross product of the horizontal and vertical tangents, smoothed over 3x3 pixels of the
/// same surface, facing the sensor.
void compute_normals(const SegmentationConfig& cfg, RangeImage* img);

/// @brief A cluster's pixel indices inside the flat member array.
struct MemberSpan {
  const int* first;
  const int* last;
  std::size_t size() const { return static_cast<std::size_t>(last - first); }
  int operator[](std::size_t i) const { return first[i]; }
  const int* begin() const { return first; }
  const int* end() const { return last; }
};

/// @brief Members of all raw clusters in one flat array (a cluster's pixels are contiguous, in growing order).
struct RawClusters {
  std::vector<int> flat;   ///< member pixels of all clusters
  std::vector<int> start;  ///< cluster i is flat[start[i] .. start[i + 1]); the last entry is flat.size()
  int num_clusters() const { return static_cast<int>(start.size()) - 1; }
  int size(int i) const { return start[to_index(i) + 1] - start[to_index(i)]; }
  MemberSpan members(int i) const { return MemberSpan{flat.data() + start[to_index(i)], flat.data() + start[to_index(i) + 1]}; }
};

/// @brief Region growing over 4-neighbours (holes of one pixel are bridged) with the two comparators of Sec. 4.2.1:
/// Euclidean 3D distance and surface-normal deviation. Seeds in row-major order.
RawClusters grow_regions(const RangeImage& img, const SegmentationConfig& cfg);

/// @brief Ids of the clusters with at least min_cluster_points, largest first (ties by first pixel: deterministic),
/// at most max_clusters.
std::vector<int> largest_clusters(const RawClusters& raw, const SegmentationConfig& cfg);

/// @brief Buffers reused from one cluster to the next (no allocation per cluster in steady state).
struct ClusterScratch {
  std::vector<Eigen::Vector3f> pts;   ///< member points
  std::vector<Eigen::Vector2f> pts2;  ///< hull candidates in the plane's (u, v) coordinates
  std::vector<int> col_lo, col_hi, row_lo, row_hi, cand, mem_row, mem_col;
};

/// @brief Centroid, PCA extents and plane test of one cluster; for planar ones the plane and its 2D convex hull; the
/// members downsampled (Sec. 4.2.1).
Cluster fit_cluster(const RangeImage& img, MemberSpan mem, const SegmentationConfig& config, ClusterScratch* scratch);

}  // namespace detail
}  // namespace loopd
