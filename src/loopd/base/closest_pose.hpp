#pragma once
// Closest-pose error (Vlaminck 2019, 5.4), shared by loop correction (trajectory_error) and evaluation.
#include <Eigen/Core>
#include <vector>

namespace loopd {

/// @brief Distance of each estimated position to its CLOSEST ground-truth position [m] (Vlaminck 2019, 5.4 and
///        Table 4: "the average distance from all poses in the estimated trajectory with its closest pose in the
///        ground truth"). No alignment is applied here; the ground truth may be denser than the estimate. Exact
///        (double precision); empty when the ground truth is empty.
std::vector<double> closest_pose_errors(const std::vector<Eigen::Vector3d>& estimate, const std::vector<Eigen::Vector3d>& ground_truth);

}  // namespace loopd
