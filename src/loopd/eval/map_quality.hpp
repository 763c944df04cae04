#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/base/voxel_accumulator.hpp"

namespace loopd {

/// @brief An axis-aligned box [m, world frame] that a moving object (a parked car that moves between visits)
///        occupies at some time of the drive; map points inside it belong to an object that is not always there.
struct MapMoverBox {
  int id = 0;       ///< the object's id (loopd-sim's movable id)
  int variant = 0;  ///< which of its positions this box is
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  /// The object left this place before the drive ended ("left", optional, default true): a map should not keep it.
  /// A box with left false is where the object stands at the end: part of the final scene, not counted.
  bool left = true;
};

/// @brief Parses the movers file written by loopd-sim: {"format":"loopd-movers","version":1,"movers":[{"id":3,
///        "variant":0,"min":[x,y,z],"max":[x,y,z]},...]}. Every field is checked (type, integer range, 3 finite
///        numbers, min <= max); `*out` is replaced only on success. Never throws.
/// @return std::nullopt, or the reason naming the field, e.g. "movers[2].min[1]: not a finite number".
std::optional<std::string> parse_movers_json(const std::string& text, std::vector<MapMoverBox>* out);

struct MapQualityConfig {
  double completeness_radius = 0.3;  ///< [m] a reference point is covered when a map point lies within this
  double mover_margin = 0.1;         ///< [m] mover boxes are grown by this on every side (points on a car's skin)
  std::optional<std::string> validate() const;
};

/// @brief How close a map is to a reference cloud of the same scene.
struct MapQuality {
  std::int64_t points = 0;             ///< finite map points evaluated
  std::int64_t reference_points = 0;   ///< finite reference points
  std::optional<double> mean_error;    ///< [m] mean over the map points of the distance to the nearest reference point
  std::optional<double> p95_error;     ///< [m] 95th percentile of the same; both nullopt when map or reference is empty
  std::optional<double> completeness;  ///< share of reference points with a map point within completeness_radius; nullopt: no reference
  std::int64_t moving_points =
      0;  ///< map points inside a box an object left (grown by mover_margin), not inside one where an object stands at the end
  double moving_points_share = 0.0;  ///< moving_points / points (0 for an empty map)
};

/// @brief Compares `map` with `reference` (both in the same frame [m]; non-finite points are ignored) with k-d trees
///        (KdTree3f): the accuracy map -> reference, the completeness reference -> map, and the moving-object
///        points left in the map.
MapQuality map_quality(const PointCloud& map, const PointCloud& reference, const std::vector<MapMoverBox>& movers, const MapQualityConfig& config);

/// @brief Points of `cloud` (non-finite ones ignored) inside any of `movers` grown by `margin` [m].
std::int64_t count_mover_points(const PointCloud& cloud, const std::vector<MapMoverBox>& movers, double margin);

}  // namespace loopd
