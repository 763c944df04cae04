#pragma once
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Copy of `cloud` without NaN/Inf points (attributes kept in step). Returns the number removed in `removed`.
PointCloud remove_non_finite(const PointCloud& cloud, std::size_t* removed = nullptr);

/// @brief Voxel-grid downsampling: one point (the centroid) per occupied voxel, in voxel key order (VoxelGrid,
/// base/voxel_grid.hpp). Intensity is averaged too; a voxel keeps the ring and time of its first point.
/// @param leaf_size [m] voxel edge; <= 0 returns a copy. Points beyond 2^20 voxels of the origin are dropped.
PointCloud voxel_downsample(const PointCloud& cloud, double leaf_size);

/// @brief Points of `cloud` mapped by T (attributes kept).
PointCloud transform(const PointCloud& cloud, const Eigen::Isometry3d& T);

/// @brief Points with min_range <= |p| <= max_range.
PointCloud crop_range(const PointCloud& cloud, double min_range, double max_range);

}  // namespace loopd
