#include "loopd/base/cloud_ops.hpp"

#include "loopd/base/voxel_grid.hpp"

#include <algorithm>
#include <cstdint>
#include <utility>

namespace loopd {
namespace {

template <typename Keep>
PointCloud filter(const PointCloud& cloud, Keep keep) {
  PointCloud out;
  out.num_rings = cloud.num_rings;
  out.points.reserve(cloud.size());
  const bool has_i = cloud.has_intensity();
  const bool has_r = cloud.ring.size() == cloud.size();
  const bool has_t = cloud.has_time();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!keep(cloud.points[i])) continue;
    out.points.push_back(cloud.points[i]);
    if (has_i) out.intensity.push_back(cloud.intensity[i]);
    if (has_r) out.ring.push_back(cloud.ring[i]);
    if (has_t) out.time.push_back(cloud.time[i]);
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
  struct IntensityAndFirst {
    double intensity = 0.0;
    std::uint32_t first = 0;  ///< lowest point index in the voxel
  };
  const bool has_i = cloud.has_intensity();
  const bool has_r = cloud.ring.size() == cloud.size();
  const bool has_t = cloud.has_time();
  VoxelGrid<IntensityAndFirst> grid(leaf_size, cloud.size());
  const double inv = 1.0 / leaf_size;
  for (std::uint32_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    // Points far outside the key range are dropped here, before the key's integer conversion could overflow.
    if (!p.allFinite() || !(p.cwiseAbs().maxCoeff() * inv <= kMaxScaledVoxelCoordinate)) continue;
    auto* v = grid.add(p);
    if (v == nullptr) continue;
    if (v->count == 1) v->payload.first = i;
    if (has_i) v->payload.intensity += cloud.intensity[i];
  }
  const auto voxels = std::move(grid).sorted_voxels();
  PointCloud out;
  out.num_rings = cloud.num_rings;
  out.points.reserve(voxels.size());
  for (const auto& v : voxels) {
    out.points.push_back(v.centroid());
    if (has_i) out.intensity.push_back(static_cast<float>(v.payload.intensity / static_cast<double>(v.count)));
    if (has_r) out.ring.push_back(cloud.ring[v.payload.first]);
    if (has_t) out.time.push_back(cloud.time[v.payload.first]);
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
