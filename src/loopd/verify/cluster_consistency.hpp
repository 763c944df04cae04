#pragma once
/// @file Geometric consistency of segment centroids after alignment (Vlaminck 2019, Sec. 4.3): are the objects of the
/// two scans still at the same place?
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/segmentation/segmentation.hpp"

namespace loopd {

/// @brief Which clusters take part and when two centroids match.
///
/// Rule (documented choice; Vlaminck 2019 gives no numbers):
/// 1. Only *compact* clusters take part (largest extent <= max_cluster_extent): poles, trunks, cars, kiosks. The
///    centroid of an extended segment (ground, a facade) depends on which part of it the sensor saw, so it moves with
///    the viewpoint (opposite direction, lane offset) even on a true loop.
/// 2. Only clusters whose centroid lies within max_range of BOTH sensor origins (after alignment) take part: objects
///    outside the common field of view cannot be expected in the other scan.
/// 3. Centroids are assigned one-to-one with the Hungarian algorithm on their 3D distance (capped at the match
///    distance, so far pairs cost the same and never steal a near pair); a pair within match_distance counts as matched.
/// 4. consistency = matched / min(n_query, n_match): the share over the SMALLER set. Objects that moved between the
///    visits (parked cars) leave extra unmatched clusters on one or both sides; dividing by the smaller set and
///    accepting a share below 1 keeps a true loop alive as long as most of the static objects agree.
struct ClusterConsistencyConfig {
  double match_distance = 1.5;      ///< [m] centroid distance for a match (a car seen from the other side shifts ~1 m)
  double max_cluster_extent = 8.0;  ///< [m] clusters with a larger principal extent are not used (rule 1)
  int min_cluster_points = 15;      ///< clusters with fewer member points are not used (noise)
  double max_range = 45.0;          ///< [m] common-field-of-view radius around both sensor origins (rule 2)
  int min_clusters = 3;             ///< fewer usable clusters on the smaller side: consistency cannot be judged

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Outcome of cluster_consistency.
struct ClusterConsistencyResult {
  double consistency = -1;    ///< matched / min(num_query, num_match); -1 when it cannot be judged
  int num_query = 0;          ///< usable query clusters
  int num_match = 0;          ///< usable match clusters
  int num_matched = 0;        ///< pairs within match_distance
  double mean_distance = -1;  ///< [m] mean centroid distance of the matched pairs
  std::string reason;         ///< non-empty when consistency is -1
};

/// @brief Matches the usable clusters of `query` (mapped by T_match_query) against those of `match`.
ClusterConsistencyResult cluster_consistency(const Segmentation& query, const Segmentation& match, const Eigen::Isometry3d& T_match_query,
                                             const ClusterConsistencyConfig& config);

}  // namespace loopd
