#pragma once
/// @file Loop verification: 4PCS, then GICP, then a degeneracy check, then the Hungarian centroid check
/// (Vlaminck 2019, Sec. 4.2-4.3; GICP after Ren 2019, Sec. 3.2). A false loop bends the whole map, so every stage
/// can reject.
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "loopd/registration/four_pcs.hpp"
#include "loopd/registration/gicp.hpp"
#include "loopd/base/information.hpp"
#include "loopd/records/prepared_scan.hpp"

namespace loopd {

/// @brief The stage that decided (kAccepted when none rejected).
enum class VerifyStage { kInput, kFourPcs, kGicp, kDegeneracy, kHungarian, kAccepted };
/// @brief "input", "fourpcs", "gicp", "degeneracy", "hungarian", "accepted".
std::string to_string(VerifyStage stage);

/// @brief Thresholds of verify(). Vlaminck 2019 gives delta = 0.5 m for 4PCS (Sec. 5.2) and epsilon = 0.001 comes from
/// Ren 2019 Eq. 3; the other values are ours, calibrated on simulated HDL-64E revisits vs near misses
/// (test/verify/test_verify.cpp) with PrepareConfig's 0.6 m voxels.
struct VerifyConfig {
  FourPcsConfig four_pcs;         ///< global alignment (delta = 0.5 m, Vlaminck 2019 Sec. 5.2)
  GicpConfig gicp;                ///< refinement started from the 4PCS estimate
  int min_points = 200;           ///< fewer voxel points in either scan: rejected at kInput
  double min_lcp_fraction = 0.5;  ///< 4PCS largest-common-point-set share needed to go on (true sim loops 0.67-0.93)
  /// [m] GICP residual (mean corresponding-point distance within the last schedule distance, 0.6 m). ~0.2 m on true
  /// loops at 0.6 m voxels; a uniform scatter inside the 0.6 m gate gives ~0.45 m.
  double max_icp_residual = 0.35;
  double min_icp_fitness = 0.5;  ///< GICP inlier share needed (Vlaminck 2019: "overlap ... should be very high")
  /// Condition number of the translational GICP information (gicp_degeneracy). Street scenes: ~2-30; a featureless
  /// tunnel: thousands.
  double max_degeneracy_ratio = 100.0;
  bool reject_degenerate = true;          ///< false: a degenerate alignment is only flagged (VerifyResult::degenerate)
  double hungarian_match_distance = 1.5;  ///< [m] centroid distance counted as the same object
  /// Share of compact clusters matched (over the smaller set). Simulated true loops with half the parked cars moved:
  /// 0.40-0.90; a different town built to the same pattern: 0.31-0.37.
  double min_hungarian_consistency = 0.35;
  double consistency_max_cluster_extent = 8.0;  ///< [m] see ClusterConsistencyConfig
  int consistency_min_cluster_points = 15;      ///< see ClusterConsistencyConfig
  double consistency_max_range = 45.0;          ///< [m] see ClusterConsistencyConfig
  int consistency_min_clusters = 3;             ///< see ClusterConsistencyConfig
  /// When too few compact clusters exist to judge the centroid check: true = reject (safe), false = pass on GICP alone.
  bool reject_unjudgeable_consistency = false;

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Decision and every score of verify(). Scores of stages that did not run stay at -1.
struct VerifyResult {
  bool accepted = false;
  VerifyStage stage = VerifyStage::kInput;                                  ///< stage that decided
  std::string reason;                                                       ///< why rejected (or what was flagged when accepted)
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();          ///< maps query points into the match frame (final estimate)
  Eigen::Isometry3d T_match_query_fourpcs = Eigen::Isometry3d::Identity();  ///< the 4PCS (or given) initial estimate
  double lcp_fraction = -1;
  double icp_residual = -1;  ///< [m]
  double icp_fitness = -1;
  double hungarian_consistency = -1;
  double degeneracy = -1;                                       ///< gicp_degeneracy of the final Hessian
  bool degenerate = false;                                      ///< degeneracy > max_degeneracy_ratio
  Eigen::Vector3d weakest_direction = Eigen::Vector3d::Zero();  ///< least-constrained translation direction (query frame)
  int icp_iterations = 0;
  bool icp_converged = false;
  int clusters_query = 0, clusters_match = 0, clusters_matched = 0;  ///< centroid check counts
  /// GICP Hessian at T_match_query as loop-edge information, in loopd's one order (base/information.hpp: t then r).
  Information6d information = Information6d::Zero();
  double ms_fourpcs = 0, ms_gicp = 0, ms_hungarian = 0, ms_total = 0;  ///< [ms]
};

/// @brief Full verification of a loop candidate: 4PCS (global, no initial guess), GICP from the 4PCS estimate,
/// Hessian degeneracy check, Hungarian centroid check. Each stage can reject; the first rejection decides.
/// @note Deterministic; never throws. An invalid config is reported as a kInput rejection.
VerifyResult verify(const PreparedScan& query, const PreparedScan& match, const VerifyConfig& config);

/// @brief The same without 4PCS: GICP starts from `init_T_match_query` (e.g. odometry, or a 4PCS result computed
/// elsewhere), then the degeneracy and centroid checks. lcp_fraction stays -1.
VerifyResult verify_from_guess(const PreparedScan& query, const PreparedScan& match, const Eigen::Isometry3d& init_T_match_query,
                               const VerifyConfig& config);

/// @brief One loop candidate as the detector verifies it. With a guess (the corrected map's relative pose right after
/// an accepted loop), GICP starts from it and 4PCS is skipped; without one, or when that guided check rejects, the
/// full verify() decides (ms_total then counts both).
VerifyResult verify_candidate(const PreparedScan& query, const PreparedScan& match, const std::optional<Eigen::Isometry3d>& guess_T_match_query,
                              const VerifyConfig& config);

}  // namespace loopd
