#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief When two poses of a drive count as a true loop (Vlaminck 2019, 5.3: "a loop is present when the
///        distance between two poses is less than 1 m", with "a threshold of 100 poses" between them).
struct LoopGroundTruthConfig {
  double max_distance = 1.0;  ///< [m] places closer than this are the same place (Vlaminck 2019, 5.3)
  int min_frame_gap = 100;    ///< [frames] a pair must be MORE than this many scans apart (Vlaminck 2019, 5.3)
  bool planar = false;        ///< measure the distance in the ground plane (drop the up axis), not in 3D
  int up_axis = 2;            ///< axis dropped when planar (2 = z, the lidar/world convention)

  std::optional<std::string> validate() const;
};

/// @brief Distance between two places under the config (3D or ground plane) [m].
double place_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const LoopGroundTruthConfig& config);

/// @brief True when the two poses form a ground-truth loop: close enough and more than min_frame_gap frames apart.
bool is_true_loop(const Eigen::Vector3d& a, std::int64_t frame_a, const Eigen::Vector3d& b, std::int64_t frame_b,
                  const LoopGroundTruthConfig& config);

/// @brief Ground-truth loops of a sequence of poses (keyframes or scans), in time order.
struct LoopGroundTruth {
  /// For each pose i, the OLDER poses j (frame_j < frame_i - min_frame_gap) closer than max_distance.
  std::vector<std::vector<int>> partners;
  std::vector<bool> revisit;  ///< partners[i] is not empty: pose i revisits an earlier place
  std::int64_t num_pairs = 0;
  int num_queries = 0;  ///< poses with at least one partner
  /// Revisited stretches: maximal runs [first, last] of consecutive indices with revisit[i].
  std::vector<std::pair<int, int>> stretches;
};

/// @brief Computes the ground-truth loops. `frames` holds the scan index of each pose in the drive (the
///        "frames apart" rule counts scans, not keyframes). Sizes of positions and frames must match.
LoopGroundTruth compute_loop_ground_truth(const std::vector<Eigen::Vector3d>& positions, const std::vector<std::int64_t>& frames,
                                          const LoopGroundTruthConfig& config);

}  // namespace loopd
