#pragma once
/// @file Fixed-radius search over a few thousand points by a hash grid of cells as wide as the radius: a query reads
/// the 8 cells that its ball's bounding box touches. 4PCS asks this once per target pair for the intermediate points
/// of a base's second diagonal; a k-d tree cost 2-3 times as much there (its descent and leaf scans per query).
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "loopd/base/voxel_grid.hpp"

namespace loopd {

class RadiusGrid {
 public:
  /// Indexes `points` (kept by reference: they must outlive the grid and not change) for queries of `radius`.
  RadiusGrid(const std::vector<Eigen::Vector3f>& points, float radius);

  /// Indices of the points p with |p - q|^2 < radius^2 (in float, as x, then y, then z squared differences summed),
  /// appended to `out` in no particular order.
  void within(const Eigen::Vector3f& q, std::vector<int>* out) const;

 private:
  struct Cell {
    int begin, end;  // range in order_
  };
  std::uint64_t cell_of(float x, float y, float z) const;
  const Cell* find(std::uint64_t key) const;

  const std::vector<Eigen::Vector3f>& points_;
  float radius_sq_, inv_cell_;
  std::vector<int> order_;   // point indices grouped by cell
  std::vector<Cell> cells_;  // one per occupied cell, indexed by table_
  VoxelKeyTable table_;      // cell key -> index in cells_
};

}  // namespace loopd
