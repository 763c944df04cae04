#pragma once
/// @file Whole-scan global registration: each scan prepared by prepare_scan() (crop, segment, voxel-downsample), then
/// plane-based 4PCS (Vlaminck 2019, Sec. 4.2). For tools and tests that align two raw scans without keyframes.
#include <optional>
#include <string>

#include "loopd/base/point_cloud.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/registration/four_pcs.hpp"

namespace loopd {

/// @brief The prepare_scan settings of whole-scan registration: 0.5 m voxels (the cloud the LCP scores, about the LCP
/// distance), points within 1-80 m, no point cap, no cached normals (4PCS needs none).
PrepareConfig registration_prepare_config();

/// @brief Settings of register_scans.
struct ScanRegistrationConfig {
  PrepareConfig prepare = registration_prepare_config();  ///< how each raw scan becomes 4PCS input
  FourPcsConfig four_pcs;

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief prepare_scan on both scans, then align_four_pcs(source -> target).
/// @param model lidar model for the segmentation's range image (nullptr: use scan.ring or derive rings)
/// @param ms_prepare optional: [ms] spent preparing both scans.
FourPcsResult register_scans(const PointCloud& source, const PointCloud& target, const LidarModel* model, const ScanRegistrationConfig& config,
                             double* ms_prepare = nullptr);

}  // namespace loopd
