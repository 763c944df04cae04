#include "loopd/registration/sweep_shape.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "loopd/base/kdtree.hpp"

namespace loopd {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

/// The knot segment of time t and its blend: the correction at t is (1 - alpha) w[k] + alpha w[k + 1].
void knot_blend(const std::vector<double>& knots, double t, int* k, double* alpha) {
  const int last = static_cast<int>(knots.size()) - 1;
  if (t <= knots.front()) {
    *k = 0, *alpha = 0.0;
    return;
  }
  if (t >= knots.back()) {
    *k = last - 1, *alpha = 1.0;
    return;
  }
  const auto it = std::upper_bound(knots.begin(), knots.end(), t);
  *k = static_cast<int>(it - knots.begin()) - 1;
  const auto i = static_cast<std::size_t>(*k);
  *alpha = (t - knots[i]) / (knots[i + 1] - knots[i]);
}

/// A sweep point on the constant-velocity path: the path's rotation and position at its time, its knot segment and
/// blend, and the point in the sensor frame.
struct PathPoint {
  Eigen::Matrix3d R0 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  int segment = 0;
  double blend = 0.0;
};

/// The reference: its points (with a k-d tree) and plane normals.
struct Reference {
  KdTree3f tree;
  const std::vector<Eigen::Vector3f>& points;
  const std::vector<Eigen::Vector3f>& normals;
};

/// Why the input cannot be shaped (empty: it can).
std::string unusable_input(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& times, const std::vector<Eigen::Vector3f>& reference,
                           const std::vector<Eigen::Vector3f>& reference_normals, const SweepShapeConfig& config) {
  if (auto e = config.validate()) return "invalid SweepShapeConfig: " + *e;
  if (config.segments == 0) return "off";
  if (points.size() != times.size() || reference.size() != reference_normals.size() || reference.empty() || points.empty())
    return "no points or no reference";
  const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
  if (!(*hi > *lo)) return "the sweep's points share one time";
  return {};
}

/// Point-to-plane terms of every point with a planar reference voxel within max_correspondence (Cauchy-weighted),
/// added to H and g; returns how many, and counts them per knot segment.
int add_point_terms(const std::vector<PathPoint>& on_path, const Eigen::VectorXd& w, const Reference& ref, const SweepShapeConfig& config,
                    Eigen::MatrixXd* H, Eigen::VectorXd* g, std::vector<int>* per_segment) {
  const float max_d2 = static_cast<float>(config.max_correspondence * config.max_correspondence);
  const double info = 1.0 / (config.plane_sigma * config.plane_sigma);
  const double cauchy2 = std::pow(2.0 * config.plane_sigma, 2);
  std::fill(per_segment->begin(), per_segment->end(), 0);
  int correspondences = 0;
  for (const PathPoint& pt : on_path) {
    const int k = pt.segment;
    const double a = pt.blend;
    const Eigen::Matrix3d A = pt.R0 * exp_so3((1.0 - a) * w.segment<3>(3 * k) + a * w.segment<3>(3 * k + 3));
    const Eigen::Vector3d q = A * pt.p + pt.t0;
    int j = -1;
    float d2 = 0.0f;
    if (!ref.tree.nearest(q.cast<float>(), &j, &d2) || d2 > max_d2) continue;
    const Eigen::Vector3d normal = ref.normals[static_cast<std::size_t>(j)].cast<double>();
    if (normal.squaredNorm() < 0.5) continue;  // no plane there
    const double e = normal.dot(q - ref.points[static_cast<std::size_t>(j)].cast<double>());
    const Eigen::Vector3d J = pt.p.cross(A.transpose() * normal);  // d e / d (right rotation at this point)
    const double weight = info / (1.0 + e * e / cauchy2);
    const double c[2] = {1.0 - a, a};
    for (int u = 0; u < 2; ++u) {
      g->segment<3>(3 * (k + u)) += weight * c[u] * e * J;
      for (int v = 0; v < 2; ++v) H->block<3, 3>(3 * (k + u), 3 * (k + v)) += weight * c[u] * c[v] * J * J.transpose();
    }
    ++(*per_segment)[static_cast<std::size_t>(k)];
    ++correspondences;
  }
  return correspondences;
}

/// The knots hold to each other: a prior of weight `prior` on w[k + 1] - w[k], added to the normal equations.
void add_knot_prior(const Eigen::VectorXd& w, double prior, Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  const int knots = static_cast<int>(w.size()) / 3;
  for (int k = 0; k + 1 < knots; ++k) {
    const Eigen::Vector3d d = w.segment<3>(3 * k + 3) - w.segment<3>(3 * k);
    g->segment<3>(3 * k) -= prior * d;
    g->segment<3>(3 * k + 3) += prior * d;
    H->block<3, 3>(3 * k, 3 * k).diagonal().array() += prior;
    H->block<3, 3>(3 * k + 3, 3 * k + 3).diagonal().array() += prior;
    H->block<3, 3>(3 * k, 3 * k + 3).diagonal().array() -= prior;
    H->block<3, 3>(3 * k + 3, 3 * k).diagonal().array() -= prior;
  }
}

/// Roll and pitch corrections held at 0: their rows and columns of the normal equations become identity rows.
void fix_tilt(Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  for (Eigen::Index k = 0; k + 2 < H->rows(); k += 3)
    for (Eigen::Index a = k; a < k + 2; ++a) {
      H->row(a).setZero();
      H->col(a).setZero();
      (*H)(a, a) = 1.0;
      (*g)(a) = 0.0;
    }
}

/// The refined path's pose at time t: the constant-velocity one turned by the knots' correction there.
Eigen::Isometry3d corrected_pose(const std::function<Eigen::Isometry3d(double)>& path, const std::vector<double>& knots, const Eigen::VectorXd& w,
                                 double t) {
  int k = 0;
  double a = 0.0;
  knot_blend(knots, t, &k, &a);
  Eigen::Isometry3d T = path(t);
  T.linear() = T.linear() * exp_so3((1.0 - a) * w.segment<3>(3 * k) + a * w.segment<3>(3 * k + 3));
  return T;
}

}  // namespace

std::optional<std::string> SweepShapeConfig::validate() const {
  if (segments < 0 || segments > 64) return "segments must be in [0, 64]";
  if (!(knot_change_sigma_deg > 0.0) || !(plane_sigma > 0.0) || !(max_correspondence > 0.0)) return "sigmas and distances must be > 0";
  if (iterations < 1 || iterations > 50) return "iterations must be in [1, 50]";
  if (min_points_per_segment < 0) return "min_points_per_segment must be >= 0";
  if (!(max_correction_deg > 0.0)) return "max_correction_deg must be > 0";
  if (!(min_rate_change_deg >= 0.0)) return "min_rate_change_deg must be >= 0";
  return std::nullopt;
}

std::vector<double> sweep_knot_times(double first, double last, int segments) {
  std::vector<double> knots;
  if (segments < 1 || !(last > first)) return knots;
  knots.reserve(static_cast<std::size_t>(segments) + 1);
  for (int k = 0; k <= segments; ++k) knots.push_back(first + (last - first) * k / segments);
  return knots;
}

SweepShapeResult refine_sweep_shape(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& times,
                                    const std::function<Eigen::Isometry3d(double)>& path_T_ref_sensor, const std::vector<Eigen::Vector3f>& reference,
                                    const std::vector<Eigen::Vector3f>& reference_normals, const SweepShapeConfig& config) {
  SweepShapeResult r;
  r.reason = unusable_input(points, times, reference, reference_normals, config);
  if (!r.reason.empty()) return r;
  const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
  r.knot_times = sweep_knot_times(*lo, *hi, config.segments);
  const int knots = static_cast<int>(r.knot_times.size());
  std::vector<PathPoint> on_path(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Isometry3d P = path_T_ref_sensor(times[i]);
    on_path[i].R0 = P.linear();
    on_path[i].t0 = P.translation();
    on_path[i].p = points[i].cast<double>();
    knot_blend(r.knot_times, times[i], &on_path[i].segment, &on_path[i].blend);
  }
  const Reference ref{KdTree3f(reference), reference, reference_normals};
  const double prior = 1.0 / std::pow(config.knot_change_sigma_deg * kDegToRad, 2);
  Eigen::VectorXd w = Eigen::VectorXd::Zero(3 * knots);
  std::vector<int> per_segment(static_cast<std::size_t>(config.segments));
  for (int iteration = 0; iteration < config.iterations; ++iteration) {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * knots, 3 * knots);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * knots);
    r.correspondences = add_point_terms(on_path, w, ref, config, &H, &g, &per_segment);
    add_knot_prior(w, prior, &H, &g);
    if (config.yaw_only) fix_tilt(&H, &g);
    H.diagonal().array() += 1e-9 * H.diagonal().maxCoeff() + 1e-12;
    const Eigen::VectorXd dw = H.ldlt().solve(-g);
    if (!dw.allFinite()) {
      r.reason = "singular system";
      return r;
    }
    w += dw;
    if (dw.cwiseAbs().maxCoeff() < 1e-6) break;
  }
  for (int k = 0; k < config.segments; ++k)
    if (per_segment[static_cast<std::size_t>(k)] < config.min_points_per_segment) {
      r.reason = "segment " + std::to_string(k) + " has " + std::to_string(per_segment[static_cast<std::size_t>(k)]) + " plane correspondences";
      return r;
    }
  for (int k = 0; k < knots; ++k) {
    r.max_correction_deg = std::max(r.max_correction_deg, w.segment<3>(3 * k).norm() / kDegToRad);
    r.T_ref_knot.push_back(corrected_pose(path_T_ref_sensor, r.knot_times, w, r.knot_times[static_cast<std::size_t>(k)]));
  }
  r.T_ref_stamp = corrected_pose(path_T_ref_sensor, r.knot_times, w, 0.0);
  if (r.max_correction_deg > config.max_correction_deg) {
    r.reason = "a knot moved " + std::to_string(r.max_correction_deg) + " deg off the constant-velocity path";
    r.T_ref_knot.clear();
    return r;
  }
  r.refined = true;
  return r;
}

}  // namespace loopd
