#include "loopd/map3d/point_mask.hpp"

#include <iostream>

namespace loopd {
namespace {
template <typename T>
std::vector<T> kept(const std::vector<T>& values, const std::vector<std::uint8_t>& remove, std::size_t num_kept) {
  std::vector<T> out;
  if (values.size() != remove.size()) return out;
  out.reserve(num_kept);
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!remove[i]) out.push_back(values[i]);
  }
  return out;
}
}  // namespace

PointCloud remove_points(const PointCloud& cloud, const std::vector<std::uint8_t>& remove) {
  if (remove.size() != cloud.size()) {
    std::cerr << "remove_points: mask of " << remove.size() << " entries for " << cloud.size() << " points; nothing removed\n";
    return cloud;
  }
  std::size_t num_kept = 0;
  for (const std::uint8_t r : remove) num_kept += r ? 0 : 1;
  PointCloud out;
  out.points = kept(cloud.points, remove, num_kept);
  out.intensity = kept(cloud.intensity, remove, num_kept);
  out.ring = kept(cloud.ring, remove, num_kept);
  out.time = kept(cloud.time, remove, num_kept);
  out.num_rings = cloud.num_rings;
  return out;
}

}  // namespace loopd
