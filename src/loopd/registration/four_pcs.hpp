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
  double delta = 0.5;                      ///< [m] LCP inlier distance, Vlaminck 2019 Sec. 5.2
  int max_bases = 16;                      ///< coplanar bases tried (ranked by width, spread over planes)
  double min_base_width = 2.0;             ///< [m] both base diagonals must be at least this long
  double pair_distance_tolerance = 0.5;    ///< [m] |q1-q2| must match the base diagonal length within this
  double intermediate_tolerance = 0.5;     ///< [m] radius for coincident intermediate points e1/e2 (Sec. 4.2.2)
  double max_angle_deviation_deg = 10.0;   ///< [deg] rigid check on the angle between the two diagonals (Sec. 4.2.2)
  double coplanar_tolerance = 0.5;         ///< [m] the 4 target points must lie this close to one target plane
  double max_tilt_deg = 25.0;              ///< [deg] max change of the up axis (ground vehicles: yaw is free, roll/pitch
                                           ///< small); also how far a target plane's tilt may differ from the base's. 180: off
  bool use_cluster_points = true;          ///< target pairs also from the downsampled planar-cluster members, not only hulls
  int max_congruent_sets_per_base = 3000;  ///< cap on congruent sets collected per base (fixed order)
  int max_scored_per_base = 90;            ///< congruent sets kept per base: lowest congruence error first
  double dedupe_rotation_deg = 2.0;        ///< [deg] candidates in an already scored pose cell (this yaw step) are skipped
  double dedupe_translation = 0.4;         ///< [m] translation step of that pose cell
  int lcp_sample_points = 600;             ///< source points scored for LCP (deterministic scrambled subsample); 0: all
  int prescreen_points = 64;               ///< every candidate is first scored on this many sample points
  double early_stop_prescore = 0.7;        ///< no further bases once a candidate's prescore fraction reaches this
  int max_full_scores = 32;                ///< the best prescored candidates get the full LCP (early-terminated)
  int refine_candidates = 3;               ///< LCP leaders refined by closest points; the best refined LCP wins
  bool lcp_exclude_ground = true;          ///< leave the source ground plane out of the LCP (it fits any yaw)
  int refine_iterations = 6;               ///< closest-point refinements (within delta) of the LCP leaders
  int num_threads = 1;                     ///< threads scoring congruent sets (the result does not depend on it)

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Outcome of align_four_pcs.
struct FourPcsResult {
  bool success = false;
  std::string reason;                                                 ///< why there is no alignment (empty on success)
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< maps source points into the target frame
  double lcp_fraction = 0;  ///< fraction of the scored source points (ground excluded) within delta of a target point
  int bases_tried = 0;
  int congruent_sets = 0;  ///< congruent sets kept and prescored (after the per-base cap and pose de-duplication)
  double ms = 0;           ///< [ms]
  int lcp_points = 0;      ///< source points the LCP fraction is computed on
};

/// @brief Global registration without initial guess (Vlaminck 2019, Sec. 4.2).
/// Bases are 4 hull points of one planar source cluster (non-horizontal planes first: a range-limited ground plane
/// matches at any yaw); congruent sets come from pairs of points lying on one target plane (hull points and
/// downsampled members); each candidate is scored by the largest common point set (LCP, delta) of a deterministic
/// subsample of the source without its ground plane (lcp_exclude_ground), then the leaders are refined by closest
/// points (ground included) and the highest LCP wins. success is true whenever a transform was found: accepting it
/// is the caller's decision on lcp_fraction (measured: revisits >= 0.7, different places <= 0.5, see tests).
/// @param source_points voxel-downsampled source cloud used for LCP scoring
/// @param target_points voxel-downsampled target cloud used for LCP scoring
/// @note Deterministic: no random sampling; the same result for any num_threads.
FourPcsResult align_four_pcs(const std::vector<Eigen::Vector3f>& source_points, const Segmentation& source_seg,
                             const std::vector<Eigen::Vector3f>& target_points, const Segmentation& target_seg, const FourPcsConfig& config);

}  // namespace loopd
