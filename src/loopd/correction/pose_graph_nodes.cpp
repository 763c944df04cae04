// Which keyframes the pose graph solves as nodes (PoseGraphConfig::reduce_chains, chain_stride, loop_end_stride).
#include <algorithm>
#include <cstdint>

#include "loopd/correction/pose_graph_internal.hpp"

namespace loopd {
namespace detail {
namespace {

/// @brief The keyframes that may be nodes: every one but the retired (`retired` sorted), and always the first (the
/// fixed gauge) and the last.
std::vector<int> kept_keyframes(std::size_t n, const std::vector<PoseIndex>& retired) {
  std::vector<int> kept;
  kept.reserve(n - std::min(n, retired.size()));
  auto r = retired.begin();
  for (std::size_t i = 0; i < n; ++i) {
    while (r != retired.end() && *r < static_cast<PoseIndex>(i)) ++r;
    if (i == 0 || i + 1 == n || r == retired.end() || *r != static_cast<PoseIndex>(i)) kept.push_back(static_cast<int>(i));
  }
  return kept;
}

/// @brief Anchors: kept keyframes that carry more than odometry (first pose, every chain_stride-th kept one, loop ends,
/// plane observations), sorted and unique. A retired loop end or observation makes the kept keyframe nearest to it a
/// node and moves there.
std::vector<int> carrying_keyframes(const std::vector<int>& kept, const std::vector<char>& is_kept, const std::vector<const LoopConstraint*>& loops,
                                    const std::vector<PlaneObservation>& planes, const PoseGraphConfig& config) {
  const std::size_t n = is_kept.size();
  std::vector<int> anchors{0};
  if (config.chain_stride > 0)
    for (std::size_t j = static_cast<std::size_t>(config.chain_stride); j < kept.size(); j += static_cast<std::size_t>(config.chain_stride))
      anchors.push_back(kept[j]);
  // A retired keyframe carries through the kept keyframe nearest to it (the earlier on a tie): the fewest steps of
  // odometry between the two.
  const auto carrier = [&](PoseIndex i) {
    if (is_kept[static_cast<std::size_t>(i)]) return static_cast<int>(i);
    const auto after = std::lower_bound(kept.begin(), kept.end(), static_cast<int>(i));  // never end(): the last is kept
    const auto before = after - 1;                                                      // never before begin(): so is the first
    return i - *before <= *after - i ? *before : *after;
  };
  for (const LoopConstraint* l : loops) {
    anchors.push_back(carrier(l->query_index));
    anchors.push_back(carrier(l->match_index));
  }
  if (config.use_plane_constraints)
    for (const PlaneObservation& o : planes)
      if (in_range(o.index, n)) anchors.push_back(carrier(o.index));
  std::sort(anchors.begin(), anchors.end());
  anchors.erase(std::unique(anchors.begin(), anchors.end()), anchors.end());
  return anchors;
}

/// @brief Nearest node of every keyframe (itself when it is one; the earlier node on a tie).
std::vector<int> nearest_nodes(const std::vector<int>& anchors, std::size_t n) {
  std::vector<int> nearest_node(n, 0);
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    const auto a = static_cast<std::size_t>(anchors[k]);
    const std::size_t b = k + 1 < anchors.size() ? static_cast<std::size_t>(anchors[k + 1]) : n;
    for (std::size_t i = a; i < b; ++i) nearest_node[i] = (k + 1 < anchors.size() && i - a > b - i) ? static_cast<int>(k + 1) : static_cast<int>(k);
  }
  return nearest_node;
}

/// @brief Both poses of every segment join (s - 1 and s) as nodes: the nearest node of any keyframe then lies in its
/// own segment, so nothing is moved through the join's (meaningless) odometry.
void add_segment_joins(std::vector<int>& anchors, std::size_t n, const std::vector<PoseIndex>& segment_starts) {
  for (const PoseIndex s : segment_starts) {
    if (s < 1 || s >= static_cast<PoseIndex>(n)) continue;
    anchors.push_back(static_cast<int>(s) - 1);
    anchors.push_back(static_cast<int>(s));
  }
  std::sort(anchors.begin(), anchors.end());
  anchors.erase(std::unique(anchors.begin(), anchors.end()), anchors.end());
}

}  // namespace

/// @brief Loops whose ends are two different poses among the n (zero-length loops and bad indices carry no information).
std::vector<const LoopConstraint*> valid_loops(const std::vector<LoopConstraint>& loops, std::size_t n) {
  std::vector<const LoopConstraint*> valid;
  for (const LoopConstraint& l : loops)
    if (in_range(l.query_index, n) && in_range(l.match_index, n) && l.query_index != l.match_index) valid.push_back(&l);
  return valid;
}

/// @brief Chooses the nodes: the carrying keyframes when they are few (reduce_chains), every loop_end_stride-th
/// keyframe when loop ends are dense, else every keyframe; with reduce_chains never more than max_nodes (a coarser
/// stride instead). Retired keyframes are never nodes: the strides count kept keyframes only.
NodeLayout choose_nodes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                        const PoseGraphConfig& config, const std::vector<PoseIndex>& segment_starts, const std::vector<PoseIndex>& retired) {
  NodeLayout layout;
  const std::vector<int> kept = kept_keyframes(n, retired);
  std::vector<char> is_kept(n, 0);
  for (int i : kept) is_kept[static_cast<std::size_t>(i)] = 1;
  const std::size_t m = kept.size();
  std::vector<int>& anchors = layout.anchors;
  anchors = carrying_keyframes(kept, is_kept, loops, planes, config);
  bool reduce = config.reduce_chains && anchors.size() * 2 < m;
  // Dense loop ends: every stride-th kept keyframe (and the last) is a node; loop ends and plane observations are moved
  // to their nearest node below.
  auto stride = static_cast<std::size_t>(config.loop_end_stride);
  bool decimate = config.reduce_chains && !reduce && stride > 1 && m > 2 * stride;
  const auto cap = static_cast<std::size_t>(config.max_nodes);
  if (config.reduce_chains && cap >= 2) {
    const std::size_t count = reduce ? anchors.size() : decimate ? (m + stride - 1) / stride + 1 : m;
    if (count > cap) {  // every k-th kept keyframe plus the last: ceil(m / k) + 1 <= cap nodes
      decimate = true;
      layout.capped = true;
      stride = std::max(stride, (m + cap - 2) / (cap - 1));
    }
  }
  if (decimate) {
    anchors.clear();
    for (std::size_t j = 0; j < m; j += stride) anchors.push_back(kept[j]);
    if (anchors.back() != static_cast<int>(n) - 1) anchors.push_back(static_cast<int>(n) - 1);
    reduce = true;
  } else if (!reduce) {
    anchors = kept;  // every keyframe when none is retired
    reduce = m < n;
  }
  if (reduce) add_segment_joins(anchors, n, segment_starts);
  layout.reduce = reduce;
  layout.nearest_node = nearest_nodes(anchors, n);
  if (m < n) {
    layout.retired.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) layout.retired[i] = is_kept[i] == 0;
  }
  return layout;
}

/// @brief Odometry from keyframe i to its node (identity for a node).
Eigen::Isometry3d to_node(const std::vector<Eigen::Isometry3d>& odometry_poses, const NodeLayout& layout, std::size_t i) {
  return odometry_poses[i].inverse() * odometry_poses[static_cast<std::size_t>(layout.anchors[static_cast<std::size_t>(layout.nearest_node[i])])];
}

}  // namespace detail
}  // namespace loopd
