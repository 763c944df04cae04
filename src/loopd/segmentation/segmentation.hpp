#pragma once
/// @file Range-image segmentation of a lidar sweep into clusters and planes (Vlaminck 2019, Sec. 4.2.1).
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

struct LidarModel;  // loopd/base/lidar_model.hpp

/// @brief Settings of the range-image region growing and plane fitting (Vlaminck 2019, Sec. 4.2.1).
struct SegmentationConfig {
  int azimuth_columns = 0;               ///< range-image columns; 0: from the LidarModel (azimuth_steps) or 1024
  int elevation_bins = 64;               ///< rings to bin elevations into when neither ring indices nor a model exist
  double min_range = 1.0;                ///< [m] points closer are ignored (ego vehicle)
  double max_range = 80.0;               ///< [m] points farther are ignored
  double max_neighbor_distance = 0.6;    ///< [m] comparator 1: max 3D distance between neighbouring pixels (near range)
  double distance_range_scale = 0.1;     ///< [m/m] allowed neighbour distance is max(max_neighbor_distance, this * range)
  double max_normal_angle_deg = 12.0;    ///< [deg] comparator 2: max deviation of neighbouring surface normals
  int min_cluster_points = 30;           ///< clusters with fewer points are dropped
  double plane_rms_tolerance = 0.08;     ///< [m] a cluster is planar when the RMS of its point-to-plane distances is below this
  double min_plane_extent = 1.0;         ///< [m] planar clusters need a second-largest extent at least this
  double keep_voxel_size = 0.7;          ///< [m] voxel size for the downsampled cluster members kept in Cluster::points
  int max_kept_points_per_cluster = 48;  ///< cap on Cluster::points (memory: PreparedScan <= ~120 KB)
  int max_hull_points = 24;              ///< cap on Cluster::hull (least-area vertices dropped first)
  double min_hull_spacing = 0.5;         ///< [m] hull vertices closer than this to the previous one are merged
  int max_clusters = 48;                 ///< keep at most this many clusters (largest first)

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief One region-growing cluster.
struct Cluster {
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();  ///< [m] mean of all member points
  int num_points = 0;                                  ///< members before downsampling
  bool planar = false;                                 ///< passed the plane fit
  Eigen::Vector4f plane = Eigen::Vector4f::Zero();     ///< (n, d): n.dot(p) + d = 0, |n| = 1 (planar only)
  std::vector<Eigen::Vector3f> points;                 ///< [m] downsampled members
  std::vector<Eigen::Vector3f> hull;                   ///< [m] convex hull of the members in the plane, CCW (planar only)
  float extent_major = 0;                              ///< [m] largest extent along the principal axis
  float extent_minor = 0;                              ///< [m] second principal extent
};

/// @brief Segmentation of one scan; `error` is non-empty when segmentation could not run.
struct Segmentation {
  std::vector<Cluster> clusters;  ///< sorted by num_points, descending
  std::string error;
  double ms = 0;  ///< [ms] run time

  /// @brief Approximate heap + object footprint [bytes].
  std::size_t bytes() const;
  int num_planar() const;
};

/// @brief Segments a scan on its range image: region growing over 4-neighbours with a 3D-distance and a normal-deviation
/// comparator, PCA plane fit per cluster, 2D convex hull of planar clusters (Vlaminck 2019, Sec. 4.2.1).
/// @param model lidar model used to derive rings from elevation when `scan` has none; nullptr: use scan.ring or bin elevations.
/// @param point_normals when given: resized to the scan and filled with each point's unit surface normal from the range
/// image (facing the sensor), zero where none is known (outside the range limits, hidden behind a nearer return in
/// its pixel, no neighbours). Costs one pass over the image: the normals are computed for the segmentation anyway.
Segmentation segment(const PointCloud& scan, const LidarModel* model, const SegmentationConfig& config,
                     std::vector<Eigen::Vector3f>* point_normals = nullptr);

}  // namespace loopd
