#include "frame_tree.hpp"

#include <set>

namespace loopd::bag2lcm {

bool FrameTree::set(const std::string& parent, const std::string& child, const Eigen::Isometry3d& T_parent_child) {
  if (parent == child) return false;
  edges_[child] = Edge{parent, T_parent_child};
  return true;
}

std::vector<std::pair<std::string, Eigen::Isometry3d>> FrameTree::ancestors(const std::string& frame) const {
  std::vector<std::pair<std::string, Eigen::Isometry3d>> chain{{frame, Eigen::Isometry3d::Identity()}};
  std::set<std::string> seen{frame};
  for (;;) {
    const auto it = edges_.find(chain.back().first);
    if (it == edges_.end() || !seen.insert(it->second.parent).second) break;  // the root, or a loop in damaged input
    chain.emplace_back(it->second.parent, it->second.T_parent_child * chain.back().second);
  }
  return chain;
}

std::optional<Eigen::Isometry3d> FrameTree::lookup(const std::string& target, const std::string& source) const {
  if (target == source) return Eigen::Isometry3d::Identity();
  const auto up_source = ancestors(source), up_target = ancestors(target);
  for (const auto& [frame, T_frame_target] : up_target)
    for (const auto& [other, T_other_source] : up_source)
      if (frame == other) return T_frame_target.inverse() * T_other_source;
  return std::nullopt;
}

std::optional<std::vector<std::string>> FrameTree::path(const std::string& target, const std::string& source) const {
  const auto up_source = ancestors(source), up_target = ancestors(target);
  for (std::size_t t = 0; t < up_target.size(); ++t)
    for (std::size_t s = 0; s < up_source.size(); ++s) {
      if (up_target[t].first != up_source[s].first) continue;
      std::vector<std::string> children;
      for (std::size_t i = 0; i < s; ++i) children.push_back(up_source[i].first);
      for (std::size_t i = 0; i < t; ++i) children.push_back(up_target[i].first);
      return children;
    }
  return std::nullopt;
}

std::string FrameTree::describe() const {
  std::string out;
  for (const auto& [child, edge] : edges_) out += (out.empty() ? "" : ", ") + edge.parent + " -> " + child;
  return out.empty() ? "none" : out;
}

}  // namespace loopd::bag2lcm
