// Which keyframes the pose graph solves as nodes (PoseGraphConfig::reduce_chains, chain_stride, loop_end_stride).
#include <algorithm>
#include <cstdint>

#include "loopd/correction/pose_graph_internal.hpp"

namespace loopd {
namespace detail {
namespace {

/// @brief Anchors: keyframes that carry more than odometry (first pose, every chain_stride-th, loop ends, plane
/// observations), sorted and unique.
std::vector<int> carrying_keyframes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                                    const PoseGraphConfig& config) {
  std::vector<int> anchors{0};
  if (config.chain_stride > 0)
    for (std::size_t i = static_cast<std::size_t>(config.chain_stride); i < n; i += static_cast<std::size_t>(config.chain_stride))
      anchors.push_back(static_cast<int>(i));
  for (const LoopConstraint* l : loops) {
    anchors.push_back(static_cast<int>(l->query_index));
    anchors.push_back(static_cast<int>(l->match_index));
  }
  if (config.use_plane_constraints)
    for (const PlaneObservation& o : planes)
      if (in_range(o.index, n)) anchors.push_back(static_cast<int>(o.index));
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
/// stride instead).
NodeLayout choose_nodes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                        const PoseGraphConfig& config, const std::vector<PoseIndex>& segment_starts) {
  NodeLayout layout;
  std::vector<int>& anchors = layout.anchors;
  anchors = carrying_keyframes(n, loops, planes, config);
  bool reduce = config.reduce_chains && anchors.size() * 2 < n;
  // Dense loop ends: every stride-th keyframe (and the last) is a node; loop ends and plane observations are moved to
  // their nearest node below.
  auto stride = static_cast<std::size_t>(config.loop_end_stride);
  bool decimate = config.reduce_chains && !reduce && stride > 1 && n > 2 * stride;
  const auto cap = static_cast<std::size_t>(config.max_nodes);
  if (config.reduce_chains && cap >= 2) {
    const std::size_t kept = reduce ? anchors.size() : decimate ? (n + stride - 1) / stride + 1 : n;
    if (kept > cap) {  // every k-th keyframe plus the last: ceil(n / k) + 1 <= cap nodes
      decimate = true;
      layout.capped = true;
      stride = std::max(stride, (n + cap - 2) / (cap - 1));
    }
  }
  if (decimate) {
    anchors.clear();
    for (std::size_t i = 0; i < n; i += stride) anchors.push_back(static_cast<int>(i));
    if (anchors.back() != static_cast<int>(n) - 1) anchors.push_back(static_cast<int>(n) - 1);
    reduce = true;
  } else if (!reduce) {
    anchors.resize(n);
    for (std::size_t i = 0; i < n; ++i) anchors[i] = static_cast<int>(i);
  }
  if (reduce) add_segment_joins(anchors, n, segment_starts);
  layout.reduce = reduce;
  layout.nearest_node = nearest_nodes(anchors, n);
  return layout;
}

/// @brief Odometry from keyframe i to its node (identity for a node).
Eigen::Isometry3d to_node(const std::vector<Eigen::Isometry3d>& odometry_poses, const NodeLayout& layout, std::size_t i) {
  return odometry_poses[i].inverse() * odometry_poses[static_cast<std::size_t>(layout.anchors[static_cast<std::size_t>(layout.nearest_node[i])])];
}

}  // namespace detail
}  // namespace loopd
