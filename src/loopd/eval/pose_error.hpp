#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "loopd/base/closest_pose.hpp"
#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief Mean / median / max of a sample of errors [m].
struct ErrorStats {
  double mean = 0, median = 0, p95 = 0, max = 0, rmse = 0;
  std::size_t count = 0;
};
ErrorStats error_stats(std::vector<double> errors);

/// closest_pose_errors (Vlaminck 2019, 5.4): loopd/base/closest_pose.hpp.

/// @brief Least-squares rigid transform T (rotation + translation, optionally scale) with T * source ~ target
///        (Umeyama 1991). Needs >= 3 non-collinear points for a unique rotation; returns identity when empty.
Eigen::Isometry3d umeyama_alignment(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target, double* scale = nullptr,
                                    bool with_scale = false);

/// @brief Absolute trajectory error: RMSE of position differences after SE(3) Umeyama alignment of estimate onto
///        ground truth (pairs associated by index) [m]. `T_gt_est` receives the alignment when given.
double ate_rmse(const std::vector<Eigen::Vector3d>& estimate, const std::vector<Eigen::Vector3d>& ground_truth,
                Eigen::Isometry3d* T_gt_est = nullptr);

/// @brief Translation [m] and rotation [deg] of the difference between an estimated and a true relative transform.
struct RelativeError {
  double translation = 0, rotation_deg = 0;
};
RelativeError relative_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth);

/// @brief Pose at `utime` from poses sorted by utime: exact hit, else interpolated between the two neighbours when
///        they are at most `max_interpolation_gap_us` apart, else the nearest pose when it is within
///        `max_nearest_gap_us`; nullopt otherwise.
std::optional<Eigen::Isometry3d> pose_at(const std::vector<StampedPose>& sorted_poses, std::int64_t utime,
                                         std::int64_t max_interpolation_gap_us = 1000000, std::int64_t max_nearest_gap_us = 100000);

}  // namespace loopd
