#include "loopd/verify/cluster_consistency.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/verify/hungarian.hpp"

namespace loopd {
namespace {

bool usable(const Cluster& c, const ClusterConsistencyConfig& cfg) {
  if (c.num_points < cfg.min_cluster_points || !c.centroid.allFinite()) return false;
  // extent_major is 0 when the segmenter did not fill it; fall back to the spread of the kept points.
  float extent = c.extent_major;
  if (!(extent > 0.f) && !c.points.empty()) {
    Eigen::Vector3f lo = c.points.front(), hi = c.points.front();
    for (const auto& p : c.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    extent = (hi - lo).norm();
  }
  return extent <= cfg.max_cluster_extent;
}

}  // namespace

std::optional<std::string> ClusterConsistencyConfig::validate() const {
  if (!(match_distance > 0.0)) return "ClusterConsistencyConfig.match_distance must be positive";
  if (!(max_cluster_extent > 0.0)) return "ClusterConsistencyConfig.max_cluster_extent must be positive";
  if (!(max_range > 0.0)) return "ClusterConsistencyConfig.max_range must be positive";
  if (min_cluster_points < 1) return "ClusterConsistencyConfig.min_cluster_points must be >= 1";
  if (min_clusters < 1) return "ClusterConsistencyConfig.min_clusters must be >= 1";
  return std::nullopt;
}

ClusterConsistencyResult cluster_consistency(const Segmentation& query, const Segmentation& match, const Eigen::Isometry3d& T_match_query,
                                             const ClusterConsistencyConfig& config) {
  ClusterConsistencyResult r;
  if (auto err = config.validate()) {
    r.reason = *err;
    return r;
  }
  // Everything in the match frame; the query sensor sits at T_match_query.translation().
  const Eigen::Vector3d query_origin = T_match_query.translation();
  const double r2 = config.max_range * config.max_range;
  auto in_common_view = [&](const Eigen::Vector3d& p) { return p.squaredNorm() <= r2 && (p - query_origin).squaredNorm() <= r2; };
  std::vector<Eigen::Vector3d> q, m;
  for (const auto& c : query.clusters) {
    if (!usable(c, config)) continue;
    const Eigen::Vector3d p = T_match_query * c.centroid.cast<double>();
    if (in_common_view(p)) q.push_back(p);
  }
  for (const auto& c : match.clusters) {
    if (!usable(c, config)) continue;
    const Eigen::Vector3d p = c.centroid.cast<double>();
    if (in_common_view(p)) m.push_back(p);
  }
  r.num_query = static_cast<int>(q.size());
  r.num_match = static_cast<int>(m.size());
  const int smaller = std::min(r.num_query, r.num_match);
  if (smaller < config.min_clusters) {
    r.reason = "too few compact clusters in the common view (query " + std::to_string(r.num_query) + ", match " + std::to_string(r.num_match) +
               ", need " + std::to_string(config.min_clusters) + ")";
    return r;
  }
  // Vlaminck 2019 Sec. 4.3: bipartite matching of centroids with the Hungarian algorithm. Costs are capped at the match
  // distance so that a pair that cannot match anyway never displaces a good one.
  Eigen::MatrixXd cost(r.num_query, r.num_match);
  for (int i = 0; i < r.num_query; ++i)
    for (int j = 0; j < r.num_match; ++j)
      cost(i, j) = std::min((q[static_cast<std::size_t>(i)] - m[static_cast<std::size_t>(j)]).norm(), config.match_distance);
  const Assignment a = hungarian_assign(cost);
  double sum = 0.0;
  for (int i = 0; i < r.num_query; ++i) {
    const int j = a.row_to_col[static_cast<std::size_t>(i)];
    if (j < 0) continue;
    const double d = (q[static_cast<std::size_t>(i)] - m[static_cast<std::size_t>(j)]).norm();
    if (d <= config.match_distance) {
      ++r.num_matched;
      sum += d;
    }
  }
  r.consistency = static_cast<double>(r.num_matched) / static_cast<double>(smaller);
  r.mean_distance = r.num_matched > 0 ? sum / r.num_matched : -1.0;
  return r;
}

}  // namespace loopd
