#pragma once
// Trajectory evaluation and synthetic drift for testing loop correction (Vlaminck 2019, Sec. 5.4 error measure).
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "loopd/correction/loop_correction.hpp"

namespace loopd {

/// @brief Pose error of an estimated trajectory against ground truth.
struct TrajectoryError {
  double mean_closest = 0;    ///< [m] mean distance of each pose to its closest ground-truth pose (Vlaminck 2019, Sec. 5.4)
  double median_closest = 0;  ///< [m] median of the same
  double max_closest = 0;     ///< [m]
  double ate_rmse = 0;        ///< [m] RMSE of position differences of same-index poses (no alignment; both start at pose 0)
};

/// @brief Errors of `estimate` against `ground_truth` (same length for ATE; closest-pose measures work for any length).
TrajectoryError trajectory_error(const std::vector<Eigen::Isometry3d>& estimate, const std::vector<Eigen::Isometry3d>& ground_truth);

/// @brief How far the two ends of a loop are from satisfying it: |t| [m] and angle [rad] of
/// (V_match T_match_query)^-1 V_query.
std::pair<double, double> loop_end_error(const std::vector<Eigen::Isometry3d>& poses, const LoopConstraint& loop);

/// @brief Drift injected into a ground-truth trajectory, step by step (odometry-like).
struct DriftConfig {
  double heading_bias = 0.0005;                        ///< [rad/m] yaw added per metre travelled (about up_axis of the sensor frame)
  double scale_bias = 0.01;                            ///< relative error of every step length
  double heading_noise = 0.0005;                       ///< [rad/sqrt(m)] random-walk yaw noise
  double tilt_noise = 0.0002;                          ///< [rad/sqrt(m)] random-walk roll/pitch noise
  double translation_noise = 0.005;                    ///< [m/sqrt(m)] per-step translation noise
  Eigen::Vector3d up_axis = Eigen::Vector3d::UnitZ();  ///< sensor up axis (KITTI camera poses: -UnitY())
  std::uint64_t seed = 42;
};

/// @brief Drifted odometry plus per-pose scan-matching residuals (larger where more error was injected).
struct DriftedTrajectory {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> residuals;  ///< residuals[i]: step ending at pose i; residuals[0] = 0
};
DriftedTrajectory inject_drift(const std::vector<Eigen::Isometry3d>& ground_truth, const DriftConfig& config);

/// @brief True loops from a ground-truth trajectory (Vlaminck 2019, Sec. 5.3: poses < max_distance apart and more
/// than min_index_gap frames apart). Queries are taken in order; a new loop must be at least min_separation frames
/// after the previous accepted query. T_match_query from ground truth. At most max_loops (<= 0: all).
std::vector<LoopConstraint> find_ground_truth_loops(const std::vector<Eigen::Isometry3d>& ground_truth, double max_distance = 1.0,
                                                    int min_index_gap = 100, int min_separation = 300, int max_loops = 0);

/// @brief A synthetic ground-truth drive: `num_poses` poses about `step` m apart, laps of a rounded rectangle
/// (side_a x side_b m) with a gentle hill, each lap shifted sideways by up to lane_offset m, so it revisits itself.
std::vector<Eigen::Isometry3d> make_lap_trajectory(int num_poses, double step = 1.0, double side_a = 120.0, double side_b = 80.0,
                                                   double lane_offset = 0.5);

}  // namespace loopd
