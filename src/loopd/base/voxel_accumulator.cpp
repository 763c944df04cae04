#include "loopd/base/voxel_accumulator.hpp"

#include <cmath>
#include <iostream>

namespace loopd {

double VoxelAccumulator::checked_leaf(double leaf) {
  if (leaf > 0.0 && std::isfinite(leaf)) return leaf;
  std::cerr << "VoxelAccumulator: leaf " << leaf << " is not a positive size; using 1 m\n";
  return 1.0;
}

VoxelAccumulator::VoxelAccumulator(double leaf) : leaf_(checked_leaf(leaf)), grid_(leaf_, 1u << 16) {}

void VoxelAccumulator::add(const Eigen::Vector3f& p, float intensity) {
  auto* voxel = p.allFinite() && p.cwiseAbs().maxCoeff() / leaf_ <= kMaxScaledVoxelCoordinate ? grid_.add(p) : nullptr;
  if (!voxel) {
    ++skipped_;
    return;
  }
  voxel->payload += std::isfinite(intensity) ? static_cast<double>(intensity) : 0.0;
  ++added_;
}

namespace {

PointCloud centroids(const std::vector<VoxelGrid<double>::Voxel>& voxels) {
  PointCloud out;
  out.reserve(voxels.size());
  for (const auto& v : voxels) {
    out.points.push_back(v.centroid());
    out.intensity.push_back(static_cast<float>(v.payload / v.count));
  }
  return out;
}

}  // namespace

PointCloud VoxelAccumulator::cloud() const& { return centroids(grid_.sorted_voxels()); }
PointCloud VoxelAccumulator::cloud() && { return centroids(std::move(grid_).sorted_voxels()); }

}  // namespace loopd
