#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief Drift injected into ground truth to make an odometry trajectory (for drives without odometry, e.g.
///        KITTI). Each ground-truth step is perturbed and the perturbed steps are chained.
struct OdometryDriftConfig {
  std::uint64_t seed = 1;                 ///< random seed (deterministic)
  double heading_bias_deg_per_m = 0.005;  ///< [deg/m] yaw added per metre travelled (constant bias)
  double scale_bias = 0.01;               ///< relative error of every step's length (0.01 = 1% too long)
  double yaw_random_walk_deg = 0.01;      ///< [deg/sqrt(step)] std-dev of the yaw noise per step
  double translation_noise = 0.005;       ///< [m/sqrt(step)] std-dev of the translation noise per step
  double residual_base = 0.02;            ///< [m] residual reported for an unperturbed step
  double residual_gain = 1.0;             ///< residual += gain * size of the injected step error [m]
  std::optional<std::string> validate() const;
};

struct OdometryDriftResult {
  std::vector<Eigen::Isometry3d> poses;  ///< odometry T_odom_sensor, equal to ground truth at index 0
  std::vector<double> residuals;         ///< per-step residual [m] (0 at index 0), higher where more drift went in
};

/// @brief Chains the perturbed relative motions of `ground_truth` (poses of the sensor, in time order).
OdometryDriftResult inject_odometry_drift(const std::vector<Eigen::Isometry3d>& ground_truth, const OdometryDriftConfig& config);

}  // namespace loopd
