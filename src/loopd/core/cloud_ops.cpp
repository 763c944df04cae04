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
  // Key: 21 bits per axis (voxel coords must lie within +-2^20 voxels of the origin).
  struct Item {
    std::uint64_t key;
    std::uint32_t index;
  };
  std::vector<Item> items;
  items.reserve(cloud.size());
  constexpr std::int64_t kOffset = 1 << 20;
  for (std::uint32_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const std::int64_t x = static_cast<std::int64_t>(std::floor(p.x() * inv)) + kOffset;
    const std::int64_t y = static_cast<std::int64_t>(std::floor(p.y() * inv)) + kOffset;
    const std::int64_t z = static_cast<std::int64_t>(std::floor(p.z() * inv)) + kOffset;
    if (x < 0 || y < 0 || z < 0 || x >= (1 << 21) || y >= (1 << 21) || z >= (1 << 21)) continue;
    items.push_back({(static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) | static_cast<std::uint64_t>(z), i});
  }
  std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.key < b.key || (a.key == b.key && a.index < b.index); });
  PointCloud out;
  out.num_rings = cloud.num_rings;
  const bool has_i = cloud.has_intensity();
  const bool has_r = cloud.ring.size() == cloud.size();
  for (std::size_t b = 0; b < items.size();) {
    std::size_t e = b;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double isum = 0.0;
    while (e < items.size() && items[e].key == items[b].key) {
      sum += cloud.points[items[e].index].cast<double>();
      if (has_i) isum += cloud.intensity[items[e].index];
      ++e;
    }
    const double n = static_cast<double>(e - b);
    out.points.push_back((sum / n).cast<float>());
    if (has_i) out.intensity.push_back(static_cast<float>(isum / n));
    if (has_r) out.ring.push_back(cloud.ring[items[b].index]);
    b = e;
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
