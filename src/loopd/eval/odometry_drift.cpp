#include "loopd/eval/odometry_drift.hpp"

#include <cmath>
#include <random>

namespace loopd {

std::optional<std::string> OdometryDriftConfig::validate() const {
  if (!std::isfinite(heading_bias_deg_per_m)) return "odometry drift: heading_bias_deg_per_m must be finite";
  if (!(scale_bias > -0.5 && scale_bias < 0.5)) return "odometry drift: scale_bias must be within (-0.5, 0.5)";
  if (!(yaw_random_walk_deg >= 0)) return "odometry drift: yaw_random_walk_deg must be >= 0";
  if (!(translation_noise >= 0)) return "odometry drift: translation_noise must be >= 0";
  if (!(residual_base >= 0) || !(residual_gain >= 0)) return "odometry drift: residual_base and residual_gain must be >= 0";
  return std::nullopt;
}

OdometryDriftResult inject_odometry_drift(const std::vector<Eigen::Isometry3d>& gt, const OdometryDriftConfig& c) {
  OdometryDriftResult r;
  if (gt.empty()) return r;
  std::mt19937_64 rng(c.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  constexpr double kDeg = M_PI / 180.0;
  r.poses.push_back(gt.front());
  r.residuals.push_back(0.0);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    const Eigen::Isometry3d step = gt[i - 1].inverse() * gt[i];
    const double length = step.translation().norm();
    const double dyaw = c.heading_bias_deg_per_m * kDeg * length + c.yaw_random_walk_deg * kDeg * normal(rng);
    const Eigen::Vector3d dt(c.translation_noise * normal(rng), c.translation_noise * normal(rng), 0.2 * c.translation_noise * normal(rng));
    Eigen::Isometry3d noisy = step;
    noisy.translation() = (1.0 + c.scale_bias) * step.translation() + dt;
    noisy.linear() = Eigen::AngleAxisd(dyaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step.linear();
    r.poses.push_back(r.poses.back() * noisy);
    // The error this step adds, in metres: translation error plus the lateral effect of the yaw error over the step.
    const double step_error = (noisy.translation() - step.translation()).norm() + std::abs(dyaw) * length;
    r.residuals.push_back(c.residual_base + c.residual_gain * step_error);
  }
  return r;
}

}  // namespace loopd
