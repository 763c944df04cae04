#pragma once
/// @file The motion between two consecutive keyframes measured by their scans: GICP of the newer keyframe's prepared
/// cloud onto the older one's, started at the odometry's step. The pose graph's odometry edges carry the odometry's
/// errors that no loop can see (a scale error of the wheels closes every lap; a degraded stretch on the only pass of a
/// street bends it): the scans of two keyframes a few metres apart overlap almost wholly and measure that step to
/// millimetres (the chain of such steps is lidar odometry, Zhang & Singh 2014; here only between keyframes).
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/information.hpp"
#include "loopd/registration/gicp.hpp"

namespace loopd {

/// @brief Settings of measure_keyframe_step.
struct KeyframeStepConfig {
  bool enabled = true;
  /// A measured step farther than this from the odometry's is not believed (a repetitive scene, a failed registration):
  /// the odometry's step stays. [m] / [deg]
  double max_translation_change = 0.5;
  double max_rotation_change_deg = 3.0;
  double min_fitness = 0.6;  ///< GICP inlier share needed
  /// Above this translational condition number (gicp_degeneracy: a corridor, a tunnel) the step is not measured.
  double max_degeneracy = 100.0;
  /// [m] The step's information is the registration's Hessian scaled so its best-determined translation direction has
  /// this standard deviation (a GICP Hessian over thousands of voxels claims far more: its errors are correlated).
  double translation_sigma = 0.01;
  /// [rad] Used only where the Hessian is unusable: a diagonal information with translation_sigma and this.
  double rotation_sigma = 0.0005;
  /// The step's tilt (its rotation about the odometry frame's horizontal axes) stays the odometry's; the scans give its
  /// heading and translation. Gravity keeps an IMU-aided odometry's roll and pitch from drifting, while registering
  /// the few rings of a VLP-16 tilts each step the same way (the simulated mine: -0.04 deg of pitch a step, summing
  /// to degrees). Needs the odometry frame's z to be up (as REP-103 odometry frames are).
  bool tilt_from_odometry = true;
  /// A scan without per-point times counts as free of skew (its step is measured) only where the odometry moved less
  /// than this between it and the scan before (one sweep or more): a handheld sensor, a slow robot. [m] / [deg]
  double max_unskewed_motion = 0.05;
  double max_unskewed_rotation_deg = 0.5;
  GicpConfig gicp = default_gicp();

  /// @brief GICP for two clouds already within centimetres of each other: 1.0 / 0.5 m correspondence stages, one thread.
  static GicpConfig default_gicp();
  std::optional<std::string> validate() const;
};

/// @brief What measure_keyframe_step found.
struct KeyframeStep {
  bool measured = false;  ///< T_previous_current is the scans' (otherwise `reason` says why not)
  Eigen::Isometry3d T_previous_current = Eigen::Isometry3d::Identity();
  Information6d information = Information6d::Zero();  ///< of T_previous_current (base/information.hpp order)
  double translation_change = 0.0;                    ///< [m] from the odometry's step
  double rotation_change_deg = 0.0;                   ///< [deg]
  double fitness = 0.0;
  double degeneracy = -1.0;
  double ms = 0.0;
  std::string reason;
};

/// @brief The pose of the newer keyframe in the older one's frame, by registering their prepared clouds (sensor frames,
///        deskewed; normals as PreparedScan::unpacked_normals(), or empty).
/// @param odometry_T_previous_current the odometry's step: the first estimate and the check on the result
/// @param R_odom_previous the older keyframe's orientation in the odometry frame (tilt_from_odometry; null: not applied)
KeyframeStep measure_keyframe_step(const std::vector<Eigen::Vector3f>& previous, const std::vector<Eigen::Vector3f>& previous_normals,
                                   const std::vector<Eigen::Vector3f>& current, const std::vector<Eigen::Vector3f>& current_normals,
                                   const Eigen::Isometry3d& odometry_T_previous_current, const KeyframeStepConfig& config,
                                   const Eigen::Matrix3d* R_odom_previous = nullptr);

}  // namespace loopd
