#pragma once
/// @file Points merged into voxels of a fixed leaf with their intensity: one centroid and mean intensity per voxel
/// (the 3D map's merge, loopd-eval's reference map). Built on the one voxel grid (base/voxel_grid.hpp); memory grows
/// with the occupied voxels, not the points.
#include <Eigen/Core>
#include <cstdint>

#include "loopd/base/point_cloud.hpp"
#include "loopd/base/voxel_grid.hpp"

namespace loopd {

class VoxelAccumulator {
 public:
  /// @param leaf [m] voxel edge (> 0; a non-positive or non-finite leaf is taken as 1 m with a warning on std::cerr).
  explicit VoxelAccumulator(double leaf);
  /// @brief Adds one point [m]; non-finite points and points outside the grid's key range (2^20 voxels of the origin)
  ///        are skipped (counted). A non-finite intensity counts as 0.
  void add(const Eigen::Vector3f& p, float intensity);
  /// @brief One point per voxel: the centroid of its points, with their mean intensity; ordered by voxel key
  ///        (deterministic for the same points).
  PointCloud cloud() const&;
  /// @brief The same, consuming the accumulator (no copy of its voxels).
  PointCloud cloud() &&;
  /// @brief Occupied voxels.
  std::size_t size() const { return grid_.size(); }
  std::int64_t points_added() const { return added_; }
  std::int64_t points_skipped() const { return skipped_; }
  double leaf() const { return leaf_; }

 private:
  static double checked_leaf(double leaf);
  double leaf_;
  VoxelGrid<double> grid_;  ///< payload: intensity sum
  std::int64_t added_ = 0, skipped_ = 0;
};

}  // namespace loopd
