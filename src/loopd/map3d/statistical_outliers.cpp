#include "loopd/map3d/statistical_outliers.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "loopd/base/kdtree.hpp"

namespace loopd {

std::optional<std::string> StatisticalOutlierConfig::validate() const {
  if (neighbours < 1) return "neighbours must be >= 1";
  if (!std::isfinite(std_ratio)) return "std_ratio must be finite";
  if (num_threads < 0) return "num_threads must be >= 0";
  return std::nullopt;
}

namespace {
// Each tested point's mean distance to its k nearest other points (the query's own entry is dropped; a duplicate
// still counts); -1 for skipped points. Each entry is written by one thread only.
std::vector<double> mean_neighbour_distances(const PointCloud& cloud, const StatisticalOutlierConfig& config, const std::vector<std::uint8_t>* skip) {
  const KdTree3f tree(cloud.points);
  const std::size_t k = static_cast<std::size_t>(config.neighbours);
  std::vector<double> score(cloud.size(), -1.0);
  const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
  const auto n = static_cast<std::int64_t>(cloud.size());
#pragma omp parallel num_threads(threads)
  {
    std::vector<int> indices(k + 1);
    std::vector<float> dists_sq(k + 1);
#pragma omp for schedule(dynamic, 256)
    for (std::int64_t q = 0; q < n; ++q) {
      const auto i = static_cast<std::size_t>(q);
      if (skip && (*skip)[i]) continue;
      const int found = tree.knn(cloud.points[i], config.neighbours + 1, indices.data(), dists_sq.data());
      double sum = 0;
      int used = 0;
      bool dropped_self = false;
      for (std::size_t j = 0; j < static_cast<std::size_t>(found) && used < config.neighbours; ++j) {
        if (!dropped_self && indices[j] == static_cast<int>(i)) {
          dropped_self = true;
          continue;
        }
        sum += std::sqrt(static_cast<double>(dists_sq[j]));
        ++used;
      }
      score[i] = used > 0 ? sum / used : -1.0;
    }
  }
  return score;
}
}  // namespace

std::vector<std::uint8_t> find_statistical_outliers(const PointCloud& cloud, const StatisticalOutlierConfig& config,
                                                    const std::vector<std::uint8_t>* skip) {
  std::vector<std::uint8_t> outlier(cloud.size(), 0);
  if (auto error = config.validate()) {
    std::cerr << "find_statistical_outliers: invalid StatisticalOutlierConfig: " << *error << "\n";
    return outlier;
  }
  if (skip && skip->size() != cloud.size()) {
    std::cerr << "find_statistical_outliers: skip mask of " << skip->size() << " entries for " << cloud.size() << " points; nothing marked\n";
    return outlier;
  }
  if (cloud.size() <= static_cast<std::size_t>(config.neighbours)) return outlier;
  const std::vector<double> score = mean_neighbour_distances(cloud, config, skip);
  // Mean and std in point order (serial): the same figures for any thread count.
  double sum = 0, sum_sq = 0;
  std::size_t tested = 0;
  for (const double s : score) {
    if (s < 0) continue;
    sum += s;
    sum_sq += s * s;
    ++tested;
  }
  if (tested < 2) return outlier;
  const double mean = sum / static_cast<double>(tested);
  const double variance = std::max(0.0, (sum_sq - sum * mean) / static_cast<double>(tested - 1));
  const double threshold = mean + config.std_ratio * std::sqrt(variance);
  for (std::size_t i = 0; i < score.size(); ++i) outlier[i] = score[i] >= 0 && score[i] > threshold ? 1 : 0;
  return outlier;
}

}  // namespace loopd
