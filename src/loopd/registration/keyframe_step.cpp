#include "loopd/registration/keyframe_step.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "loopd/base/pose.hpp"
#include "loopd/base/stopwatch.hpp"

namespace loopd {

GicpConfig KeyframeStepConfig::default_gicp() { return near_clouds_gicp(2000); }

std::optional<std::string> KeyframeStepConfig::validate() const {
  if (!(max_translation_change > 0.0) || !(max_rotation_change_deg > 0.0)) return "max_translation_change and max_rotation_change_deg must be > 0";
  if (!(min_fitness >= 0.0 && min_fitness <= 1.0)) return "min_fitness must be in [0, 1]";
  if (!(max_unskewed_motion >= 0.0) || !(max_unskewed_rotation_deg >= 0.0)) return "max_unskewed_motion and max_unskewed_rotation_deg must be >= 0";
  if (!(max_degeneracy >= 1.0)) return "max_degeneracy must be >= 1";
  if (!(translation_sigma > 0.0 && std::isfinite(translation_sigma)) || !(rotation_sigma > 0.0 && std::isfinite(rotation_sigma)))
    return "translation_sigma and rotation_sigma must be > 0";
  if (auto e = gicp.validate()) return "gicp: " + *e;
  return std::nullopt;
}

namespace {

/// The registration's Hessian as the step's information, scaled so its best-determined translation has
/// translation_sigma: the shape (a street's weak along-track direction, the rotation's lever arm) is the scans', the
/// scale a measured one (a GICP Hessian over thousands of voxels claims far more: its errors are correlated).
Information6d step_information(const Eigen::Matrix<double, 6, 6>& H_rotation_first, const KeyframeStepConfig& config) {
  Information6d information = information_from_rotation_first(H_rotation_first);
  information = 0.5 * (information + information.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(information.topLeftCorner<3, 3>());
  const double largest = translation.eigenvalues().maxCoeff();
  if (!(largest > 0.0) || !information.allFinite()) {
    Eigen::Matrix<double, 6, 1> d;
    d << Eigen::Vector3d::Constant(1.0 / (config.translation_sigma * config.translation_sigma)),
        Eigen::Vector3d::Constant(1.0 / (config.rotation_sigma * config.rotation_sigma));
    return d.asDiagonal();
  }
  return information * (1.0 / (config.translation_sigma * config.translation_sigma * largest));
}

/// The measured step with the odometry's tilt: the rotation between the two steps, in the odometry frame, keeps only
/// its component about the frame's z (the heading the scans measured); its horizontal components are undone.
Eigen::Isometry3d with_odometry_tilt(const Eigen::Isometry3d& T_measured, const Eigen::Isometry3d& T_odometry,
                                     const Eigen::Matrix3d& R_odom_previous) {
  const Eigen::Matrix3d R_odom_current = R_odom_previous * T_measured.linear();
  const Eigen::AngleAxisd difference(T_measured.linear().transpose() * T_odometry.linear());  // in the current frame
  const Eigen::Vector3d tilt_odom = R_odom_current * (difference.angle() * difference.axis());
  const Eigen::Vector3d tilt = R_odom_current.transpose() * Eigen::Vector3d(tilt_odom.x(), tilt_odom.y(), 0.0);
  Eigen::Isometry3d T = T_measured;
  if (tilt.norm() > 0.0) T.linear() = T_measured.linear() * Eigen::AngleAxisd(tilt.norm(), tilt.normalized()).toRotationMatrix();
  return T;
}

}  // namespace

KeyframeStep measure_keyframe_step(const std::vector<Eigen::Vector3f>& previous, const std::vector<Eigen::Vector3f>& previous_normals,
                                   const std::vector<Eigen::Vector3f>& current, const std::vector<Eigen::Vector3f>& current_normals,
                                   const Eigen::Isometry3d& odometry_T_previous_current, const KeyframeStepConfig& config,
                                   const Eigen::Matrix3d* R_odom_previous) {
  Stopwatch watch;
  KeyframeStep step;
  step.T_previous_current = odometry_T_previous_current;
  const GicpResult g = align_gicp(current, current_normals, previous, previous_normals, odometry_T_previous_current, config.gicp);
  step.ms = watch.ms();
  step.fitness = g.fitness;
  step.degeneracy = g.degeneracy;
  const Eigen::Isometry3d change = odometry_T_previous_current.inverse() * g.T_target_source;
  step.translation_change = change.translation().norm();
  step.rotation_change_deg = rotation_angle(change) * 180.0 / M_PI;
  if (!g.converged) {
    step.reason = "registration did not converge: " + g.reason;
  } else if (g.fitness < config.min_fitness) {
    step.reason = "fitness " + std::to_string(g.fitness) + " < " + std::to_string(config.min_fitness);
  } else if (!(g.degeneracy >= 1.0 && g.degeneracy <= config.max_degeneracy)) {
    step.reason = "degenerate: translational condition " + std::to_string(g.degeneracy);
  } else if (step.translation_change > config.max_translation_change || step.rotation_change_deg > config.max_rotation_change_deg) {
    step.reason =
        "disagrees with the odometry by " + std::to_string(step.translation_change) + " m / " + std::to_string(step.rotation_change_deg) + " deg";
  } else {
    step.measured = true;
    step.T_previous_current = g.T_target_source;
    step.information = step_information(g.H, config);
    if (config.tilt_from_odometry && R_odom_previous != nullptr)
      step.T_previous_current = with_odometry_tilt(step.T_previous_current, odometry_T_previous_current, *R_odom_previous);
  }
  return step;
}

}  // namespace loopd
