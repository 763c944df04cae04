#include "loopd/correction/trajectory_tools.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "loopd/base/closest_pose.hpp"

namespace loopd {

TrajectoryError trajectory_error(const std::vector<Eigen::Isometry3d>& estimate, const std::vector<Eigen::Isometry3d>& ground_truth) {
  TrajectoryError e;
  if (estimate.empty() || ground_truth.empty()) return e;
  std::vector<Eigen::Vector3d> est_positions, gt_positions;
  est_positions.reserve(estimate.size());
  gt_positions.reserve(ground_truth.size());
  for (const auto& T : estimate) est_positions.push_back(T.translation());
  for (const auto& T : ground_truth) gt_positions.push_back(T.translation());
  std::vector<double> d = closest_pose_errors(est_positions, gt_positions);
  double ate = 0.0;
  std::size_t ate_n = 0;
  for (std::size_t i = 0; i < estimate.size() && i < ground_truth.size(); ++i) {
    ate += (estimate[i].translation() - ground_truth[i].translation()).squaredNorm();
    ++ate_n;
  }
  double sum = 0.0;
  for (double v : d) sum += v;
  e.mean_closest = sum / static_cast<double>(d.size());
  e.max_closest = *std::max_element(d.begin(), d.end());
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  e.median_closest = d[d.size() / 2];
  e.ate_rmse = ate_n ? std::sqrt(ate / static_cast<double>(ate_n)) : 0.0;
  return e;
}

std::pair<double, double> loop_end_error(const std::vector<Eigen::Isometry3d>& poses, const LoopConstraint& loop) {
  const int n = static_cast<int>(poses.size());
  if (loop.query_index < 0 || loop.match_index < 0 || loop.query_index >= n || loop.match_index >= n) return {0.0, 0.0};
  const Eigen::Isometry3d E =
      (poses[static_cast<std::size_t>(loop.match_index)] * loop.T_match_query).inverse() * poses[static_cast<std::size_t>(loop.query_index)];
  const double c = std::clamp((E.linear().trace() - 1.0) * 0.5, -1.0, 1.0);
  return {E.translation().norm(), std::acos(c)};
}

DriftedTrajectory inject_drift(const std::vector<Eigen::Isometry3d>& gt, const DriftConfig& config) {
  DriftedTrajectory out;
  if (gt.empty()) return out;
  std::mt19937_64 rng(config.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d up = config.up_axis.normalized();
  // Two axes orthogonal to up for roll/pitch noise.
  const Eigen::Vector3d a1 = up.unitOrthogonal();
  const Eigen::Vector3d a2 = up.cross(a1);
  out.poses.push_back(gt[0]);
  out.residuals.push_back(0.0);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    const Eigen::Isometry3d Z = gt[i - 1].inverse() * gt[i];
    const double len = Z.translation().norm();
    const double sq = std::sqrt(len);
    const double yaw_noise = config.heading_noise * sq * normal(rng);
    const double yaw = config.heading_bias * len + yaw_noise;
    const double tilt1 = config.tilt_noise * sq * normal(rng), tilt2 = config.tilt_noise * sq * normal(rng);
    const Eigen::Vector3d t_noise(config.translation_noise * sq * normal(rng), config.translation_noise * sq * normal(rng),
                                  config.translation_noise * sq * normal(rng));
    const Eigen::Matrix3d R_err = (Eigen::AngleAxisd(yaw, up) * Eigen::AngleAxisd(tilt1, a1) * Eigen::AngleAxisd(tilt2, a2)).toRotationMatrix();
    Eigen::Isometry3d Zd = Z;
    Zd.translation() = (1.0 + config.scale_bias) * Z.translation() + t_noise;
    Zd.linear() = Z.linear() * R_err;
    out.poses.push_back(out.poses.back() * Zd);
    // A scan-matching residual that grows with the injected random error (what a real front end would report).
    const double residual = 0.02 + t_noise.norm() + 5.0 * (std::abs(yaw_noise) + std::abs(tilt1) + std::abs(tilt2));
    out.residuals.push_back(residual);
  }
  return out;
}

std::vector<LoopConstraint> find_ground_truth_loops(const std::vector<Eigen::Isometry3d>& gt, double max_distance, int min_index_gap,
                                                    int min_separation, int max_loops) {
  std::vector<LoopConstraint> loops;
  const int n = static_cast<int>(gt.size());
  int last_query = -1000000000;
  for (int j = min_index_gap + 1; j < n; ++j) {
    if (j - last_query < min_separation) continue;
    int best = -1;
    double best_d = max_distance;
    for (int i = 0; i + min_index_gap < j; ++i) {
      const double d = (gt[static_cast<std::size_t>(i)].translation() - gt[static_cast<std::size_t>(j)].translation()).norm();
      if (d < best_d) {
        best_d = d;
        best = i;
      }
    }
    if (best < 0) continue;
    LoopConstraint l;
    l.query_index = j;
    l.match_index = best;
    l.T_match_query = gt[static_cast<std::size_t>(best)].inverse() * gt[static_cast<std::size_t>(j)];
    loops.push_back(l);
    last_query = j;
    if (max_loops > 0 && static_cast<int>(loops.size()) >= max_loops) break;
  }
  return loops;
}

std::vector<Eigen::Isometry3d> make_lap_trajectory(int num_poses, double step, double side_a, double side_b, double lane_offset) {
  // Rounded rectangle: two straights of side_a, two of side_b, joined by quarter circles of radius r.
  const double r = 15.0;
  const double perimeter = 2.0 * side_a + 2.0 * side_b + 2.0 * M_PI * r;
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(static_cast<std::size_t>(std::max(num_poses, 0)));
  for (int k = 0; k < num_poses; ++k) {
    const double s_total = k * step;
    const int lap = static_cast<int>(s_total / perimeter);
    double s = std::fmod(s_total, perimeter);
    const double lateral = lane_offset * std::sin(1.7 * lap);  // a different lane each lap
    // Walk the segments: straight, corner, straight, corner, ...
    const double segs[4] = {side_a, side_b, side_a, side_b};
    double x = 0, y = 0, yaw = 0;
    for (int seg = 0; seg < 4; ++seg) {
      if (s <= segs[seg]) {
        x += s * std::cos(yaw);
        y += s * std::sin(yaw);
        s = -1;
        break;
      }
      x += segs[seg] * std::cos(yaw);
      y += segs[seg] * std::sin(yaw);
      s -= segs[seg];
      const double corner = 0.5 * M_PI * r;
      const double a = std::min(s, corner) / r;
      // Left turn of angle a about the centre at r to the left.
      const double cx = x - r * std::sin(yaw), cy = y + r * std::cos(yaw);
      x = cx + r * std::sin(yaw + a);
      y = cy - r * std::cos(yaw + a);
      yaw += a;
      if (s <= corner) {
        s = -1;
        break;
      }
      s -= corner;
    }
    const double nx = -std::sin(yaw), ny = std::cos(yaw);
    const double z = 2.0 * std::sin(2.0 * M_PI * std::fmod(s_total, perimeter) / perimeter);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(x + lateral * nx, y + lateral * ny, z);
    poses.push_back(T);
  }
  return poses;
}

}  // namespace loopd
