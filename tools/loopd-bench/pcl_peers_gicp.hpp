#pragma once
// PCL's GeneralizedIterativeClosestPoint as the benchmark peer of loopd's GICP. No PCL types in this header.
#include <Eigen/Geometry>
#include <vector>

namespace loopd::bench {

struct PclGicpResult {
  bool available = false;  ///< false when built without PCL
  bool converged = false;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double ms = 0;  ///< [ms] setInputSource/Target + align (covariances included, as in loopd's align_gicp)
};

/// @brief pcl::GeneralizedIterativeClosestPoint<PointXYZ> from `init` with its k-neighbour covariances (k),
/// one correspondence distance and an iteration cap.
PclGicpResult pcl_gicp_align(const std::vector<Eigen::Vector3f>& source, const std::vector<Eigen::Vector3f>& target, const Eigen::Isometry3d& init,
                             double max_correspondence_distance, int max_iterations, int k_neighbors);

}  // namespace loopd::bench
