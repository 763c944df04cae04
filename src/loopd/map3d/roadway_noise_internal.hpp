#pragma once
/// @file Internals of roadway_noise.cpp: the section's four parts and their curves (Ren 2019, Sec. 3.5, Steps 3-4).
#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "loopd/map3d/roadway_noise.hpp"

namespace loopd::detail {

/// @brief The parts S1..S4 of a roadway section (Ren 2019, Sec. 3.5, Step 3).
enum class RoadwaySector { kRoof = 0, kFloor = 1, kLeftWall = 2, kRightWall = 3 };
constexpr int kRoadwaySectors = 4;

/// @brief Part of a section point (a lateral [m], left positive; b up [m]) by its angle around the station at (0, 0):
/// roof within 45 deg of up, floor within 45 deg of down, walls to either side.
inline RoadwaySector sector_of(double a, double b) {
  if (b >= std::abs(a)) return RoadwaySector::kRoof;
  if (-b >= std::abs(a)) return RoadwaySector::kFloor;
  return a > 0 ? RoadwaySector::kLeftWall : RoadwaySector::kRightWall;
}

/// @brief A fitted section curve: the line n.(a, b) = d (unit n) of a floor or wall, or the roof b = c0 + c1 a + c2 a^2
/// (a quadratic, so an arched roof fits too).
struct SectionCurve {
  bool quadratic = false;
  Eigen::Vector3d coef = Eigen::Vector3d::Zero();  ///< line: (n_a, n_b, d); roof: (c0, c1, c2)

  /// @brief Signed distance [m] of (a, b) from the curve (first order for the roof: residual / sqrt(1 + slope^2)).
  double signed_distance(double a, double b) const {
    if (!quadratic) return coef[0] * a + coef[1] * b - coef[2];
    const double slope = coef[1] + 2 * coef[2] * a;
    return (b - (coef[0] + coef[1] * a + coef[2] * a * a)) / std::sqrt(1 + slope * slope);
  }
};

/// @brief Ren 2019, Sec. 3.5, Step 4: RANSAC of the sector's curve (a line, or a quadratic for the roof), then least
/// squares on its inliers.
/// @return nullopt when the sector does not count: fewer than min_sector_points points or inliers, an inlier share
/// below min_inlier_share, or no curve of the sector's orientation (floor near horizontal, walls near vertical, roof
/// no steeper than 60 deg).
std::optional<SectionCurve> fit_section_curve(const std::vector<Eigen::Vector2d>& points, RoadwaySector sector, const RoadwayNoiseConfig& config,
                                              std::mt19937* rng);

}  // namespace loopd::detail
