#pragma once
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>

#include "loopd/core/point_cloud.hpp"

namespace loopd {

/// @brief Copy of `cloud` without NaN/Inf points (attributes kept in step). Returns the number removed in `removed`.
PointCloud remove_non_finite(const PointCloud& cloud, std::size_t* removed = nullptr);

/// @brief Voxel-grid downsampling: one point (the centroid) per occupied voxel. Deterministic order.
/// @param leaf_size [m] voxel edge; <= 0 returns a copy.
PointCloud voxel_downsample(const PointCloud& cloud, double leaf_size);

/// @brief Points of `cloud` mapped by T (attributes kept).
PointCloud transform(const PointCloud& cloud, const Eigen::Isometry3d& T);

/// @brief Points with min_range <= |p| <= max_range.
PointCloud crop_range(const PointCloud& cloud, double min_range, double max_range);

namespace detail {
/// @brief Slot of a packed voxel key (x << 42 | y << 21 | z) in an open-addressing table of `capacity` (a power of
/// two) slots. Every key bit reaches the low bits (murmur3's 64-bit finaliser): a plain multiply-and-shift that keeps
/// middle bits ignores x entirely, and whole rows of voxels then share one probe chain.
inline std::size_t voxel_slot(std::uint64_t key, std::size_t capacity) {
  key ^= key >> 33;
  key *= 0xff51afd7ed558ccdULL;
  key ^= key >> 33;
  key *= 0xc4ceb9fe1a85ec53ULL;
  key ^= key >> 33;
  return static_cast<std::size_t>(key) & (capacity - 1);
}
}  // namespace detail

}  // namespace loopd
