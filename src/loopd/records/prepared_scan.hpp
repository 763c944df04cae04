#pragma once
/// @file What a keyframe keeps for loop verification: a voxel-downsampled cloud, its cached GICP normals and the
/// segmentation of the full-resolution scan. Plain data: built by prepare_scan() (pipeline/prepare_scan.hpp), read by
/// verify(), and what the map store persists.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

/// @brief A unit vector quantised to int8 per axis (value * 127); (0, 0, 0) means "none". 3 bytes.
struct PackedNormal {
  std::int8_t x = 0, y = 0, z = 0;
};

/// @brief A scan prepared for verify(): everything 4PCS, GICP and the centroid check need, nothing more.
struct PreparedScan {
  std::vector<Eigen::Vector3f> points;  ///< [m] voxel-downsampled, range-cropped, finite (sensor frame)
  /// GICP normals of `points` (from the range image, or estimate_gicp_normals; see PrepareConfig), cached so a
  /// keyframe's covariances are computed once, not once per loop candidate; (0, 0, 0): none known (isotropic
  /// covariance). Empty: verify() estimates them. Quantisation error <= ~0.5 deg.
  std::vector<PackedNormal> normals;
  Segmentation segmentation;      ///< clusters of the full-resolution scan (Vlaminck 2019, Sec. 4.2.1)
  std::size_t input_points = 0;   ///< points in the raw scan
  std::size_t finite_points = 0;  ///< after dropping NaN/Inf
  double ms_segmentation = 0;     ///< [ms]
  double ms_total = 0;            ///< [ms] whole prepare_scan
  std::string error;              ///< non-empty when the scan is unusable (verify() then rejects at kInput)

  /// @brief Heap + object footprint [bytes] (target <= ~120 KB for an HDL-64E town scan).
  std::size_t bytes() const;
  /// @brief `normals` as unit float vectors (empty when `normals` does not match `points`).
  std::vector<Eigen::Vector3f> unpacked_normals() const;
};

}  // namespace loopd
