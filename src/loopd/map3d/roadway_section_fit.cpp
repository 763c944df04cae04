// The curves of a roadway section's four parts (Ren 2019, Sec. 3.5, Step 4): RANSAC picks the curve with the most
// inliers among candidates through random point pairs (lines) or triples (the roof's quadratic), then least squares is
// run on its inliers (twice, re-selecting them), and the sector counts only when the refined curve holds its share.
#include <Eigen/Dense>
#include <algorithm>

#include "loopd/map3d/roadway_noise_internal.hpp"

namespace loopd::detail {
namespace {
constexpr double kMaxRoofSlope = 1.7320508075688772;  // tan 60 deg: steeper is a wall (an open street's walls reach the roof sector)
constexpr double kMinSampleSpread = 0.1;              // [m] sample points closer than this define no curve
constexpr int kRefits = 2;                            // least-squares passes, each on the inliers of the previous curve

bool line_through(const Eigen::Vector2d& p, const Eigen::Vector2d& q, SectionCurve* curve) {
  const Eigen::Vector2d d = q - p;
  const double length = d.norm();
  if (length < kMinSampleSpread) return false;
  const Eigen::Vector2d n(-d.y() / length, d.x() / length);
  curve->quadratic = false;
  curve->coef << n.x(), n.y(), n.dot(p);
  return true;
}

bool quadratic_through(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, SectionCurve* curve) {
  if (std::abs(p.x() - q.x()) < kMinSampleSpread || std::abs(q.x() - r.x()) < kMinSampleSpread || std::abs(p.x() - r.x()) < kMinSampleSpread)
    return false;
  Eigen::Matrix3d vandermonde;
  vandermonde << 1, p.x(), p.x() * p.x(), 1, q.x(), q.x() * q.x(), 1, r.x(), r.x() * r.x();
  curve->quadratic = true;
  curve->coef = vandermonde.partialPivLu().solve(Eigen::Vector3d(p.y(), q.y(), r.y()));
  return curve->coef.allFinite();
}

// The curve has its sector's orientation over [a_min, a_max]: floor lines near horizontal, wall lines near vertical,
// the roof no steeper than kMaxRoofSlope (its slope is linear in a, so the ends bound it).
bool oriented(const SectionCurve& curve, RoadwaySector sector, double a_min, double a_max, double cos_tilt) {
  if (curve.quadratic) {
    const double slope_min = curve.coef[1] + 2 * curve.coef[2] * a_min, slope_max = curve.coef[1] + 2 * curve.coef[2] * a_max;
    return std::abs(slope_min) <= kMaxRoofSlope && std::abs(slope_max) <= kMaxRoofSlope;
  }
  const double along_normal = sector == RoadwaySector::kFloor || sector == RoadwaySector::kRoof ? curve.coef[1] : curve.coef[0];
  return std::abs(along_normal) >= cos_tilt;
}

int count_inliers(const SectionCurve& curve, const std::vector<Eigen::Vector2d>& points, std::size_t stride, double tolerance) {
  int count = 0;
  for (std::size_t i = 0; i < points.size(); i += stride) count += std::abs(curve.signed_distance(points[i].x(), points[i].y())) <= tolerance ? 1 : 0;
  return count;
}

std::vector<Eigen::Vector2d> inliers_of(const SectionCurve& curve, const std::vector<Eigen::Vector2d>& points, double tolerance) {
  std::vector<Eigen::Vector2d> inliers;
  for (const auto& p : points) {
    if (std::abs(curve.signed_distance(p.x(), p.y())) <= tolerance) inliers.push_back(p);
  }
  return inliers;
}

// Least squares on the inliers: the total-least-squares line (smallest principal axis as normal), or the roof's
// quadratic by its normal equations.
bool least_squares(const std::vector<Eigen::Vector2d>& inliers, SectionCurve* curve) {
  if (curve->quadratic) {
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (const auto& p : inliers) {
      const Eigen::Vector3d row(1, p.x(), p.x() * p.x());
      normal_matrix += row * row.transpose();
      rhs += row * p.y();
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(normal_matrix);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
    curve->coef = ldlt.solve(rhs);
    return curve->coef.allFinite();
  }
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : inliers) mean += p;
  mean /= static_cast<double>(inliers.size());
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  for (const auto& p : inliers) covariance += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance);
  const Eigen::Vector2d n = eig.eigenvectors().col(0);  // eigenvalues ascending: the normal of the best line
  curve->coef << n.x(), n.y(), n.dot(mean);
  return true;
}

std::pair<double, double> abscissa_range(const std::vector<Eigen::Vector2d>& points) {
  double lo = points.front().x(), hi = lo;
  for (const auto& p : points) {
    lo = std::min(lo, p.x());
    hi = std::max(hi, p.x());
  }
  return {lo, hi};
}

// RANSAC: the candidate with the most inliers among the strided scoring points (the first one found on ties).
std::optional<SectionCurve> ransac(const std::vector<Eigen::Vector2d>& points, RoadwaySector sector, const RoadwayNoiseConfig& config,
                                   std::mt19937* rng) {
  const bool roof = sector == RoadwaySector::kRoof;
  const double cos_tilt = std::cos(config.max_surface_tilt_deg * M_PI / 180.0);
  const std::size_t n = points.size();
  const std::size_t limit = static_cast<std::size_t>(config.ransac_max_points);
  const std::size_t stride = std::max<std::size_t>(1, (n + limit - 1) / limit);
  std::optional<SectionCurve> best;
  int best_count = -1;
  for (int it = 0; it < config.ransac_iterations; ++it) {
    const Eigen::Vector2d& p = points[(*rng)() % n];
    const Eigen::Vector2d& q = points[(*rng)() % n];
    const Eigen::Vector2d& r = points[(*rng)() % n];
    SectionCurve candidate;
    if (!(roof ? quadratic_through(p, q, r, &candidate) : line_through(p, q, &candidate))) continue;
    const double a_min = std::min({p.x(), q.x(), r.x()}), a_max = std::max({p.x(), q.x(), r.x()});
    if (!oriented(candidate, sector, a_min, a_max, cos_tilt)) continue;
    const int count = count_inliers(candidate, points, stride, config.inlier_distance);
    if (count > best_count) {
      best_count = count;
      best = candidate;
    }
  }
  return best;
}
}  // namespace

std::optional<SectionCurve> fit_section_curve(const std::vector<Eigen::Vector2d>& points, RoadwaySector sector, const RoadwayNoiseConfig& config,
                                              std::mt19937* rng) {
  if (points.size() < static_cast<std::size_t>(config.min_sector_points)) return std::nullopt;
  std::optional<SectionCurve> curve = ransac(points, sector, config, rng);
  if (!curve) return std::nullopt;
  std::vector<Eigen::Vector2d> inliers;
  for (int pass = 0; pass < kRefits; ++pass) {
    inliers = inliers_of(*curve, points, config.inlier_distance);
    if (inliers.size() < static_cast<std::size_t>(config.min_sector_points) || !least_squares(inliers, &*curve)) return std::nullopt;
  }
  inliers = inliers_of(*curve, points, config.inlier_distance);
  if (inliers.size() < static_cast<std::size_t>(config.min_sector_points)) return std::nullopt;
  if (static_cast<double>(inliers.size()) < config.min_inlier_share * static_cast<double>(points.size())) return std::nullopt;
  const auto [a_min, a_max] = abscissa_range(inliers);
  if (!oriented(*curve, sector, a_min, a_max, std::cos(config.max_surface_tilt_deg * M_PI / 180.0))) return std::nullopt;
  return curve;
}

}  // namespace loopd::detail
