#pragma once
/// @file Whole-scan global registration: crop, segment, voxel-downsample, then plane-based 4PCS (Vlaminck 2019, Sec. 4.2).
#include <optional>
#include <string>
#include <vector>

#include "loopd/core/point_cloud.hpp"
#include "loopd/registration/four_pcs.hpp"
#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

/// @brief How a raw scan is turned into 4PCS input.
struct ScanRegistrationConfig {
  double voxel_size = 0.5;   ///< [m] voxel of the cloud scored by the LCP
  double min_range = 1.0;    ///< [m] closer points are dropped (ego vehicle)
  double max_range = 80.0;   ///< [m] farther points are dropped
  SegmentationConfig segmentation;
  FourPcsConfig four_pcs;

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief A scan ready for align_four_pcs: downsampled points + segmentation (what a keyframe caches).
struct RegistrationInput {
  std::vector<Eigen::Vector3f> points;  ///< [m] voxel-downsampled, cropped, finite
  Segmentation segmentation;
  double ms = 0;  ///< [ms] preparation time (segmentation included)
};

/// @brief Filters non-finite points, crops by range, segments (with `model` when given) and voxel-downsamples.
RegistrationInput prepare_registration_input(const PointCloud& scan, const LidarModel* model, const ScanRegistrationConfig& config);

/// @brief prepare_registration_input on both scans, then align_four_pcs(source -> target).
/// @param ms_prepare optional: [ms] spent preparing both scans.
FourPcsResult register_scans(const PointCloud& source, const PointCloud& target, const LidarModel* model, const ScanRegistrationConfig& config,
                             double* ms_prepare = nullptr);

}  // namespace loopd
