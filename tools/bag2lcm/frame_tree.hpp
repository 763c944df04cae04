#pragma once
// A tree of coordinate frames as ROS TF keeps it (each child has one parent), without ROS types: bag2lcm fills it from
// /tf_static and /tf and asks for the transform between two frames.
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace loopd::bag2lcm {

class FrameTree {
 public:
  /// @brief Sets T_parent_child (maps child coordinates into the parent); replaces the child's earlier edge.
  ///        An edge from a frame to itself is ignored (false).
  bool set(const std::string& parent, const std::string& child, const Eigen::Isometry3d& T_parent_child);
  /// @brief T_target_source, through the frames' nearest common ancestor; nullopt when they are not connected (or a
  ///        damaged tree loops). Identity when target == source.
  std::optional<Eigen::Isometry3d> lookup(const std::string& target, const std::string& source) const;
  /// @brief The child frames of the edges on the path from `source` to `target`, those on the source side first
  ///        (each edge is named by its child); nullopt when not connected.
  std::optional<std::vector<std::string>> path(const std::string& target, const std::string& source) const;
  bool has_edge(const std::string& child) const { return edges_.count(child) > 0; }
  /// @brief "parent -> child" of every edge, for error messages.
  std::string describe() const;
  std::size_t size() const { return edges_.size(); }

 private:
  struct Edge {
    std::string parent;
    Eigen::Isometry3d T_parent_child;
  };
  /// Frames from `frame` up to its root, with T_ancestor_frame for each; stops at a loop.
  std::vector<std::pair<std::string, Eigen::Isometry3d>> ancestors(const std::string& frame) const;
  std::map<std::string, Edge> edges_;  ///< by child frame
};

}  // namespace loopd::bag2lcm
