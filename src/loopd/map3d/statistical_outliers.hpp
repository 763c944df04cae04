#pragma once
/// @file Statistical outlier detection for the 3D map (the idea of PCL's StatisticalOutlierRemoval): the map's noise
/// off the roadways, where the section-based removal (roadway_noise) does not apply.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Settings of find_statistical_outliers.
struct StatisticalOutlierConfig {
  int neighbours = 8;      ///< k: nearest neighbours whose mean distance is a point's score
  double std_ratio = 2.0;  ///< a point is an outlier when its score > mean + std_ratio * std of all scores
  int num_threads = 0;     ///< OpenMP threads for the k-NN queries (0: OpenMP's default); results do not depend on it

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Marks the statistical outliers of `cloud`: points whose mean distance to their k nearest neighbours exceeds
/// the mean of that score over the tested points by more than std_ratio standard deviations.
/// @param skip optional, one entry per point: 1 = neither tested nor marked (e.g. RoadwayNoiseResult::in_tunnel); such
/// points still count as neighbours of the others, but not in the mean and std.
/// @return one entry per point, 1 = outlier. All 0 when the config is invalid (a std::cerr line), a skip mask has
/// another size (a std::cerr line), or fewer than k + 1 points exist.
std::vector<std::uint8_t> find_statistical_outliers(const PointCloud& cloud, const StatisticalOutlierConfig& config,
                                                    const std::vector<std::uint8_t>* skip = nullptr);

}  // namespace loopd
