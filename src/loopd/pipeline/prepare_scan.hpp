#pragma once
/// @file The one keyframe preparer: raw scan -> PreparedScan (segmentation, voxel cloud, cached GICP normals).
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/records/prepared_scan.hpp"
#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

struct LidarModel;  // loopd/base/lidar_model.hpp

/// @brief Settings of prepare_scan.
///
/// Voxel size 0.6 m (justification): an HDL-64E street scan cropped to 2-60 m leaves ~5.5-7k voxels at 0.6 m, which
/// fits the keyframe memory budget (15 B a point with its packed normal, plus ~20 KB of segmentation) and keeps GICP
/// near 1.7 ms CPU per Gauss-Newton iteration. The voxel is about the 4PCS LCP distance (0.5 m, Vlaminck 2019 Sec. 5.2)
/// and the final GICP correspondence distance, so no structure finer than what those stages resolve is thrown away;
/// poles, kerbs and car bodies still get several points. On the simulated revisits 0.6 m gives final errors of a few
/// mm / < 0.02 deg (loopd-bench gicp), far inside the 0.2 m / 1 deg acceptance; 1.0 m and up starts dropping poles.
struct PrepareConfig {
  double voxel_size = 0.6;        ///< [m] voxel edge for `points`
  double min_range = 2.0;         ///< [m] drop the ego vehicle
  double max_range = 60.0;        ///< [m] far points are sparse and barely overlap between two visits
  std::size_t max_points = 6000;  ///< cap on `points` (deterministic stride subsample beyond it; memory budget); 0: no cap
  int normal_k_neighbors = 20;    ///< neighbours for the cached GICP normals (GicpConfig::k_neighbors); 0: cache none
  /// Cached GICP normals from the segmentation's range image (computed there anyway, at full resolution): the mean of
  /// the point normals in each voxel. A voxel whose point normals disagree (an edge, a corner, foliage: length of the
  /// mean below this) gets none, i.e. an isotropic covariance. 0: PCA of the normal_k_neighbors nearest voxel
  /// centroids instead (Ren 2019, Eq. 2; also the fallback when the segmentation failed).
  double range_image_normal_coherence = 0.8;
  int num_threads = 2;              ///< threads for the normal estimation
  SegmentationConfig segmentation;  ///< its own range limits are overridden by min_range / max_range

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Filters NaN/Inf, crops to [min_range, max_range], segments the cropped full-resolution scan, voxel-downsamples.
/// @param model lidar model for the segmentation's range image (nullptr: use scan.ring or derive rings)
/// @note Never throws on bad input: an empty or all-NaN scan gives a PreparedScan with `error` set.
PreparedScan prepare_scan(const PointCloud& scan, const LidarModel* model, const PrepareConfig& config);

}  // namespace loopd
