#include "loopd/eval/pose_error.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace loopd {

ErrorStats error_stats(std::vector<double> e) {
  ErrorStats s;
  s.count = e.size();
  if (e.empty()) return s;
  std::sort(e.begin(), e.end());
  double sum = 0, sum2 = 0;
  for (double v : e) {
    sum += v;
    sum2 += v * v;
  }
  const double n = static_cast<double>(e.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum2 / n);
  const std::size_t mid = e.size() / 2;
  s.median = (e.size() % 2 == 1) ? e[mid] : 0.5 * (e[mid - 1] + e[mid]);
  const std::size_t i95 = std::min(e.size() - 1, static_cast<std::size_t>(std::ceil(0.95 * n)) - 1);
  s.p95 = e[i95];
  s.max = e.back();
  return s;
}

Eigen::Isometry3d umeyama_alignment(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target, double* scale,
                                    bool with_scale) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (scale) *scale = 1.0;
  const std::size_t n = std::min(source.size(), target.size());
  if (n == 0) return T;
  Eigen::Vector3d mu_s = Eigen::Vector3d::Zero(), mu_t = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mu_s += source[i];
    mu_t += target[i];
  }
  mu_s /= static_cast<double>(n);
  mu_t /= static_cast<double>(n);
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  double var_s = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d ds = source[i] - mu_s;
    sigma += (target[i] - mu_t) * ds.transpose();
    var_s += ds.squaredNorm();
  }
  sigma /= static_cast<double>(n);
  var_s /= static_cast<double>(n);
  // Umeyama 1991, Eq. (38)-(42): R = U S V^T with S fixing a reflection.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  double c = 1.0;
  if (with_scale && var_s > 0) c = (svd.singularValues().asDiagonal() * S).trace() / var_s;
  T.linear() = R;
  T.translation() = mu_t - c * R * mu_s;
  if (scale) *scale = c;
  return T;
}

double ate_rmse(const std::vector<Eigen::Vector3d>& estimate, const std::vector<Eigen::Vector3d>& ground_truth, Eigen::Isometry3d* T_gt_est) {
  const std::size_t n = std::min(estimate.size(), ground_truth.size());
  if (n == 0) return 0.0;
  const Eigen::Isometry3d T = umeyama_alignment(estimate, ground_truth);
  if (T_gt_est) *T_gt_est = T;
  double sum2 = 0;
  for (std::size_t i = 0; i < n; ++i) sum2 += (T * estimate[i] - ground_truth[i]).squaredNorm();
  return std::sqrt(sum2 / static_cast<double>(n));
}

RelativeError relative_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d d = truth.inverse() * estimate;
  RelativeError e;
  e.translation = d.translation().norm();
  e.rotation_deg = rotation_angle(d) * 180.0 / M_PI;
  return e;
}

std::optional<Eigen::Isometry3d> pose_at(const std::vector<StampedPose>& poses, std::int64_t utime, std::int64_t max_interpolation_gap_us,
                                         std::int64_t max_nearest_gap_us) {
  if (poses.empty()) return std::nullopt;
  const auto it = std::lower_bound(poses.begin(), poses.end(), utime, [](const StampedPose& p, std::int64_t t) { return p.utime < t; });
  if (it != poses.end() && it->utime == utime) return it->T_world_sensor;
  if (it != poses.end() && it != poses.begin()) {
    const StampedPose& a = *(it - 1);
    const StampedPose& b = *it;
    if (b.utime - a.utime <= max_interpolation_gap_us) {
      const double alpha = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
      return interpolate(a.T_world_sensor, b.T_world_sensor, alpha);
    }
  }
  const StampedPose* nearest = nullptr;
  std::int64_t best = std::numeric_limits<std::int64_t>::max();
  if (it != poses.end()) {
    nearest = &*it;
    best = it->utime - utime;
  }
  if (it != poses.begin() && utime - (it - 1)->utime < best) {
    nearest = &*(it - 1);
    best = utime - (it - 1)->utime;
  }
  if (nearest && best <= max_nearest_gap_us) return nearest->T_world_sensor;
  return std::nullopt;
}

}  // namespace loopd
