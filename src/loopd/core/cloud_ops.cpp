#include "loopd/core/cloud_ops.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

namespace loopd {
namespace {

template <typename Keep>
PointCloud filter(const PointCloud& cloud, Keep keep) {
  PointCloud out;
  out.num_rings = cloud.num_rings;
  out.points.reserve(cloud.size());
  const bool has_i = cloud.has_intensity();
  const bool has_r = cloud.ring.size() == cloud.size();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!keep(cloud.points[i])) continue;
    out.points.push_back(cloud.points[i]);
    if (has_i) out.intensity.push_back(cloud.intensity[i]);
    if (has_r) out.ring.push_back(cloud.ring[i]);
  }
  return out;
}

}  // namespace

PointCloud remove_non_finite(const PointCloud& cloud, std::size_t* removed) {
  PointCloud out = filter(cloud, [](const Eigen::Vector3f& p) { return p.allFinite(); });
  if (removed) *removed = cloud.size() - out.size();
  return out;
}

PointCloud crop_range(const PointCloud& cloud, double min_range, double max_range) {
  const float lo = static_cast<float>(min_range * min_range), hi = static_cast<float>(max_range * max_range);
  return filter(cloud, [&](const Eigen::Vector3f& p) {
    const float d = p.squaredNorm();
    return d >= lo && d <= hi;
  });
}

PointCloud voxel_downsample(const PointCloud& cloud, double leaf_size) {
  if (leaf_size <= 0.0) return cloud;
  const double inv = 1.0 / leaf_size;
  // Key: 21 bits per axis (voxel coords must lie within +-2^20 voxels of the origin). Points are accumulated in an
  // open-addressing hash table in index order, then the occupied voxels are sorted by key: the output order and
  // every sum are deterministic, and the cost is O(n) + O(m log m) for m voxels instead of sorting all n points.
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t capacity = 16;
  while (capacity < 2 * cloud.size()) capacity <<= 1;
  std::vector<std::uint64_t> slot_key(capacity, kEmpty);
  std::vector<std::uint32_t> slot_voxel(capacity);
  struct Voxel {
    std::uint64_t key;
    Eigen::Vector3d sum;
    double intensity;
    std::uint32_t count;
    std::uint32_t first;  ///< lowest point index in the voxel
  };
  std::vector<Voxel> voxels;
  const bool has_i = cloud.has_intensity();
  const bool has_r = cloud.ring.size() == cloud.size();
  for (std::uint32_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const std::int64_t x = static_cast<std::int64_t>(std::floor(p.x() * inv)) + kOffset;
    const std::int64_t y = static_cast<std::int64_t>(std::floor(p.y() * inv)) + kOffset;
    const std::int64_t z = static_cast<std::int64_t>(std::floor(p.z() * inv)) + kOffset;
    if (x < 0 || y < 0 || z < 0 || x >= (1 << 21) || y >= (1 << 21) || z >= (1 << 21)) continue;
    const std::uint64_t key = (static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) | static_cast<std::uint64_t>(z);
    std::size_t h = detail::voxel_slot(key, capacity);
    while (slot_key[h] != kEmpty && slot_key[h] != key) h = (h + 1) & (capacity - 1);
    if (slot_key[h] == kEmpty) {
      slot_key[h] = key;
      slot_voxel[h] = static_cast<std::uint32_t>(voxels.size());
      voxels.push_back({key, Eigen::Vector3d::Zero(), 0.0, 0, i});
    }
    Voxel& v = voxels[slot_voxel[h]];
    v.sum += p.cast<double>();
    if (has_i) v.intensity += cloud.intensity[i];
    ++v.count;
  }
  std::sort(voxels.begin(), voxels.end(), [](const Voxel& a, const Voxel& b) { return a.key < b.key; });
  PointCloud out;
  out.num_rings = cloud.num_rings;
  out.points.reserve(voxels.size());
  for (const Voxel& v : voxels) {
    const double n = static_cast<double>(v.count);
    out.points.push_back((v.sum / n).cast<float>());
    if (has_i) out.intensity.push_back(static_cast<float>(v.intensity / n));
    if (has_r) out.ring.push_back(cloud.ring[v.first]);
  }
  return out;
}

PointCloud transform(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  PointCloud out = cloud;
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (auto& p : out.points) p = Tf * p;
  return out;
}

}  // namespace loopd
