#pragma once
/// @file Deterministic plane-based four-point congruent sets (Vlaminck 2019, Sec. 4.2; Aiger 2008).
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

/// @brief Settings of the plane-based 4PCS global registration.
struct FourPcsConfig {
  double delta = 0.5;               ///< [m] LCP inlier distance, Vlaminck 2019 Sec. 5.2
  int max_bases = 16;               ///< coplanar bases tried (ranked by width, spread over planes)
  double min_base_width = 2.0;      ///< [m] shortest allowed base diagonal
  double pair_distance_tolerance = 0.5;  ///< [m] |q1-q2| must match the base segment length within this (0: use delta)
  double intermediate_tolerance = 0.5;   ///< [m] e1/e2 coincidence radius (0: use delta)
  double max_angle_deviation_deg = 8.0;  ///< [deg] rigid check on the angle between the two segments
  int max_congruent_sets_per_base = 2000;  ///< cap per base (deterministic: first in fixed order)
  int max_target_pair_points = 1500;  ///< cap on target planar points used to form pairs
  int lcp_sample_points = 600;        ///< source points scored for LCP (deterministic stride subsample); 0: all
  double early_stop_lcp = 0.95;       ///< stop trying bases when this LCP fraction is reached
  int num_threads = 1;                ///< threads for scoring congruent sets (result does not depend on it)

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Outcome of align_four_pcs.
struct FourPcsResult {
  bool success = false;
  std::string reason;  ///< why there is no alignment (empty on success)
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< maps source points into the target frame
  double lcp_fraction = 0;  ///< fraction of (scored) source points within delta of a target point
  int bases_tried = 0;
  int congruent_sets = 0;  ///< congruent sets whose transform was scored
  double ms = 0;           ///< [ms]
};

/// @brief Global registration without initial guess (Vlaminck 2019, Sec. 4.2).
/// Bases are taken on planar clusters of the source, congruent sets among planar-cluster points of the target,
/// each candidate scored by the largest common point set (LCP) on the full downsampled clouds.
/// @param source_points voxel-downsampled source cloud used for LCP scoring
/// @param target_points voxel-downsampled target cloud used for LCP scoring
/// @note Deterministic: no random sampling; the same result for any num_threads.
FourPcsResult align_four_pcs(const std::vector<Eigen::Vector3f>& source_points, const Segmentation& source_seg,
                             const std::vector<Eigen::Vector3f>& target_points, const Segmentation& target_seg,
                             const FourPcsConfig& config);

}  // namespace loopd
