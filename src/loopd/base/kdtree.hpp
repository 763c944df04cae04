#pragma once
#include <Eigen/Core>
#include <memory>
#include <vector>

namespace loopd {

/// @brief 3D k-d tree over a point vector (nanoflann inside; the points must outlive the tree).
class KdTree3f {
 public:
  explicit KdTree3f(const std::vector<Eigen::Vector3f>& points, int leaf_size = 16);
  ~KdTree3f();
  KdTree3f(const KdTree3f&) = delete;
  KdTree3f& operator=(const KdTree3f&) = delete;

  /// @brief Nearest neighbour; returns false when the tree is empty. dist_sq in [m^2].
  bool nearest(const Eigen::Vector3f& q, int* index, float* dist_sq) const;
  /// @brief k nearest neighbours, closest first; returns how many were found.
  int knn(const Eigen::Vector3f& q, int k, int* indices, float* dists_sq) const;
  /// @brief All points within radius [m]; indices appended to out (unsorted).
  void radius(const Eigen::Vector3f& q, float radius, std::vector<int>* out) const;
  std::size_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace loopd
