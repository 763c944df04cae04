#include "loopd/eval/loop_ground_truth.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace loopd {

std::optional<std::string> LoopGroundTruthConfig::validate() const {
  if (!(max_distance > 0.0) || !std::isfinite(max_distance)) return "loop ground truth: max_distance must be > 0 m";
  if (min_frame_gap < 0) return "loop ground truth: min_frame_gap must be >= 0";
  if (up_axis < 0 || up_axis > 2) return "loop ground truth: up_axis must be 0, 1 or 2";
  return std::nullopt;
}

double place_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const LoopGroundTruthConfig& config) {
  Eigen::Vector3d d = a - b;
  if (config.planar) d(config.up_axis) = 0.0;
  return d.norm();
}

bool is_true_loop(const Eigen::Vector3d& a, std::int64_t frame_a, const Eigen::Vector3d& b, std::int64_t frame_b,
                  const LoopGroundTruthConfig& config) {
  const std::int64_t gap = frame_a > frame_b ? frame_a - frame_b : frame_b - frame_a;
  return gap > config.min_frame_gap && place_distance(a, b, config) < config.max_distance;
}

LoopGroundTruth compute_loop_ground_truth(const std::vector<Eigen::Vector3d>& positions, const std::vector<std::int64_t>& frames,
                                          const LoopGroundTruthConfig& config) {
  LoopGroundTruth gt;
  const int n = static_cast<int>(std::min(positions.size(), frames.size()));
  gt.partners.assign(static_cast<std::size_t>(n), {});
  gt.revisit.assign(static_cast<std::size_t>(n), false);
  // Sweep over poses sorted by one horizontal coordinate: only neighbours within max_distance along that axis can
  // be partners, so long drives (tens of thousands of scans) stay far below O(n^2).
  const int sort_axis = (config.planar && config.up_axis == 0) ? 1 : 0;
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return positions[static_cast<std::size_t>(a)](sort_axis) < positions[static_cast<std::size_t>(b)](sort_axis); });
  for (int oi = 0; oi < n; ++oi) {
    const int i = order[static_cast<std::size_t>(oi)];
    const Eigen::Vector3d& pi = positions[static_cast<std::size_t>(i)];
    for (int oj = oi + 1; oj < n; ++oj) {
      const int j = order[static_cast<std::size_t>(oj)];
      const Eigen::Vector3d& pj = positions[static_cast<std::size_t>(j)];
      if (pj(sort_axis) - pi(sort_axis) >= config.max_distance) break;
      if (!is_true_loop(pi, frames[static_cast<std::size_t>(i)], pj, frames[static_cast<std::size_t>(j)], config)) continue;
      const bool i_newer = frames[static_cast<std::size_t>(i)] > frames[static_cast<std::size_t>(j)];
      const int q = i_newer ? i : j;
      const int m = i_newer ? j : i;
      gt.partners[static_cast<std::size_t>(q)].push_back(m);
      ++gt.num_pairs;
    }
  }
  for (int i = 0; i < n; ++i) {
    auto& p = gt.partners[static_cast<std::size_t>(i)];
    std::sort(p.begin(), p.end());
    gt.revisit[static_cast<std::size_t>(i)] = !p.empty();
    if (!p.empty()) ++gt.num_queries;
  }
  for (int i = 0; i < n; ++i) {
    if (!gt.revisit[static_cast<std::size_t>(i)]) continue;
    int j = i;
    while (j + 1 < n && gt.revisit[static_cast<std::size_t>(j + 1)]) ++j;
    gt.stretches.emplace_back(i, j);
    i = j;
  }
  return gt;
}

}  // namespace loopd
