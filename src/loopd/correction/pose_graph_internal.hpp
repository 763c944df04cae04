#pragma once
// Private to loopd_correction: the steps of optimize_pose_graph() (pose_graph.cpp: edges, chain filling), one file
// each: pose_graph_nodes.cpp (which keyframes are solved as nodes) and pose_graph_solve.cpp (the Ceres solve).
// No Ceres types here.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "loopd/correction/pose_graph.hpp"

namespace loopd {
namespace detail {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// @brief One edge of the graph being solved (node indices of that graph).
struct GraphEdge {
  int a = 0, b = 0;
  Eigen::Isometry3d Z = Eigen::Isometry3d::Identity();  ///< measured T_a_b
  Matrix6d sqrt_info = Matrix6d::Identity();            ///< square root of the information, (t, r) order
  bool robust = false;                                  ///< a loop edge: gets the robust kernel
};

/// @brief Whether `index` (a keyframe position) names one of `n` poses.
inline bool in_range(std::int64_t index, std::size_t n) { return index >= 0 && index < static_cast<std::int64_t>(n); }

/// @brief Loops whose ends are two different poses among the n (zero-length loops and bad indices carry no information).
std::vector<const LoopConstraint*> valid_loops(const std::vector<LoopConstraint>& loops, std::size_t n);

/// @brief The keyframes solved as nodes and, for every keyframe, its nearest node.
struct NodeLayout {
  std::vector<int> anchors;       ///< keyframe of each node, increasing
  std::vector<int> nearest_node;  ///< per keyframe: its nearest node (itself when it is one)
  bool reduce = false;            ///< false: every keyframe is a node
  bool capped = false;            ///< max_nodes made the nodes sparser than the loops: one loop edge per node pair
};

/// @brief Chooses the nodes: the carrying keyframes when they are few (reduce_chains), every loop_end_stride-th
/// keyframe when loop ends are dense, else every keyframe; both poses of every segment join are always nodes.
NodeLayout choose_nodes(std::size_t n, const std::vector<const LoopConstraint*>& loops, const std::vector<PlaneObservation>& planes,
                        const PoseGraphConfig& config, const std::vector<PoseIndex>& segment_starts = {});

/// @brief Odometry from keyframe i to its node (identity for a node).
Eigen::Isometry3d to_node(const std::vector<Eigen::Isometry3d>& odometry_poses, const NodeLayout& layout, std::size_t i);

/// @brief Solves a graph over `poses` (node 0 fixed) in place: relative-pose edges, and plane observations (index =
/// node) when config.use_plane_constraints; fills result's converged, iterations, costs, message and planes.
void solve_graph(std::vector<Eigen::Isometry3d>& poses, const std::vector<GraphEdge>& edges, const std::vector<PlaneObservation>& planes,
                 const PoseGraphConfig& config, PoseGraphResult& result);

}  // namespace detail
}  // namespace loopd
