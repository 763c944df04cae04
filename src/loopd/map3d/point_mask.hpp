#pragma once
/// @file Dropping the points a map-cleaning stage marked (roadway_noise, statistical_outliers) with their attributes.
#include <cstdint>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief The points of `cloud` whose `remove` entry is 0, in their order, with the attributes that are sized like the
/// points (intensity, ring, time) kept aligned; attributes of another size come back empty. num_rings is copied.
/// @param remove one entry per point (1: drop). A mask of another size is a caller's error: a std::cerr line and the
/// cloud unchanged.
PointCloud remove_points(const PointCloud& cloud, const std::vector<std::uint8_t>& remove);

}  // namespace loopd
