#include "loopd/map3d/occupancy_map.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <fstream>

#include "loopd/map3d/key_sort.hpp"

namespace loopd {

std::optional<std::string> OccupancyMapConfig::validate() const {
  if (!(resolution >= 0.02 && resolution <= 5.0)) return "map octree resolution must be in [0.02, 5] m";
  if (!(ray_max_range > resolution) || !std::isfinite(ray_max_range)) return "map ray_max_range must be finite and > the resolution";
  if (!(prob_hit > 0.5 && prob_hit < 1.0)) return "map prob_hit must be in (0.5, 1)";
  if (!(prob_miss > 0.0 && prob_miss < 0.5)) return "map prob_miss must be in (0, 0.5)";
  if (!(clamping_min > 0.0 && clamping_min < 0.5 && clamping_max > 0.5 && clamping_max < 1.0)) return "map clamping must be in (0, 0.5) and (0.5, 1)";
  return std::nullopt;
}

struct OccupancyMap::Impl {
  explicit Impl(double resolution) : tree(resolution) {}
  octomap::OcTree tree;
};

OccupancyMap::OccupancyMap(const OccupancyMapConfig& config) : config_(config), impl_(std::make_unique<Impl>(config.resolution)) {
  impl_->tree.setProbHit(config.prob_hit);
  impl_->tree.setProbMiss(config.prob_miss);
  impl_->tree.setClampingThresMin(config.clamping_min);
  impl_->tree.setClampingThresMax(config.clamping_max);
}

OccupancyMap::~OccupancyMap() = default;

namespace {

std::uint64_t packed(const octomap::OcTreeKey& k) { return std::uint64_t{k[0]} << 32 | std::uint64_t{k[1]} << 16 | k[2]; }
octomap::OcTreeKey unpacked(std::uint64_t v) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>(v >> 32), static_cast<octomap::key_type>(v >> 16), static_cast<octomap::key_type>(v));
}
/// A direct-mapped cache of the leaf keys met last: the rays of one scan share their leaves near the sensor, so most
/// keys repeat within a few rays, and sorting every repeat away took 45 % of a map export. Dropping a key that the
/// cache still holds loses nothing: sort_unique_keys() after it would remove it anyway (a repeat the cache forgot is
/// removed there), so the set of keys, and the map, are the same.
class RecentKeys {
 public:
  RecentKeys() : slots_(kSlots, kEmpty) {}
  bool first_time(std::uint64_t key) {
    std::uint64_t& slot = slots_[static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - kBits))];
    if (slot == key) return false;
    slot = key;
    return true;
  }

 private:
  static constexpr int kBits = 14;
  static constexpr std::size_t kSlots = std::size_t{1} << kBits;
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no packed key: a key_type is 16 bits, packed into 48
  std::vector<std::uint64_t> slots_;
};

/// Appends the sorted `part` to the sorted `*all`, keeping it sorted (each thread's keys are sorted once, not again).
void merge_sorted(const std::vector<std::uint64_t>& part, std::vector<std::uint64_t>* all) {
  const auto middle = static_cast<std::ptrdiff_t>(all->size());
  all->insert(all->end(), part.begin(), part.end());
  std::inplace_merge(all->begin(), all->begin() + middle, all->end());
}

}  // namespace

void OccupancyMap::insert_scan(const PointCloud& cloud_world, const Eigen::Vector3d& origin_world, const std::vector<float>& free_margin) {
  const octomap::OcTree& tree = impl_->tree;
  const Eigen::Vector3f origin = origin_world.cast<float>();
  const octomap::point3d o(origin.x(), origin.y(), origin.z());
  const auto n = static_cast<std::ptrdiff_t>(cloud_world.size());
  const bool margins = free_margin.size() == cloud_world.size();
  std::vector<std::uint64_t> hits, misses;
#pragma omp parallel
  {
    std::vector<std::uint64_t> my_hits, my_misses;
    RecentKeys recent;
    octomap::KeyRay ray;
#pragma omp for schedule(dynamic, 256) nowait
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = cloud_world.points[static_cast<std::size_t>(i)];
      if (!p.allFinite()) continue;
      const Eigen::Vector3f d = p - origin;
      const float range = d.norm();
      if (!(range > 0.0f)) continue;
      const float reach = std::min(static_cast<float>(config_.ray_max_range), range) - (margins ? free_margin[static_cast<std::size_t>(i)] : 0.0f);
      octomap::OcTreeKey key;
      if (range <= config_.ray_max_range && tree.coordToKeyChecked(octomap::point3d(p.x(), p.y(), p.z()), key)) my_hits.push_back(packed(key));
      if (reach <= 0.0f) continue;
      const Eigen::Vector3f e = origin + d * (reach / range);
      if (tree.computeRayKeys(o, octomap::point3d(e.x(), e.y(), e.z()), ray))
        for (const octomap::OcTreeKey& k : ray) {
          const std::uint64_t key = packed(k);
          if (recent.first_time(key)) my_misses.push_back(key);
        }
    }
    sort_unique_keys(&my_hits);
    sort_unique_keys(&my_misses);
#pragma omp critical
    {
      merge_sorted(my_hits, &hits);
      merge_sorted(my_misses, &misses);
    }
  }
  hits.erase(std::unique(hits.begin(), hits.end()), hits.end());
  misses.erase(std::unique(misses.begin(), misses.end()), misses.end());
  // A leaf hit in this scan is not also missed (OctoMap's insertPointCloud gives hits the same precedence).
  std::vector<std::uint64_t> free_only;
  free_only.reserve(misses.size());
  std::set_difference(misses.begin(), misses.end(), hits.begin(), hits.end(), std::back_inserter(free_only));
  for (std::uint64_t k : free_only) impl_->tree.updateNode(unpacked(k), false, /*lazy_eval=*/true);
  for (std::uint64_t k : hits) impl_->tree.updateNode(unpacked(k), true, /*lazy_eval=*/true);
}

Occupancy OccupancyMap::at(const Eigen::Vector3f& p) const {
  // Lazy insertion leaves inner nodes stale, but search() descends to the leaf, whose value is current.
  const octomap::OcTreeNode* node = impl_->tree.search(p.x(), p.y(), p.z());
  if (node == nullptr) return Occupancy::kUnknown;
  return impl_->tree.isNodeOccupied(node) ? Occupancy::kOccupied : Occupancy::kFree;
}

std::vector<std::uint8_t> OccupancyMap::free_points(const PointCloud& cloud_world) const {
  std::vector<std::uint8_t> free(cloud_world.size(), 0);
  const auto n = static_cast<std::ptrdiff_t>(cloud_world.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = cloud_world.points[static_cast<std::size_t>(i)];
    free[static_cast<std::size_t>(i)] = p.allFinite() && at(p) == Occupancy::kFree ? 1 : 0;
  }
  return free;
}

std::optional<std::string> OccupancyMap::write_binary(const std::string& path) {
  impl_->tree.updateInnerOccupancy();
  std::ofstream out(path, std::ios::binary);
  if (!out) return "cannot write " + path;
  if (!impl_->tree.writeBinary(out)) return path + ": OctoMap could not write the tree";
  out.flush();
  if (!out) return path + ": write failed";
  return std::nullopt;
}

std::size_t OccupancyMap::leaves() const { return impl_->tree.getNumLeafNodes(); }
std::size_t OccupancyMap::memory_bytes() const { return impl_->tree.memoryUsage(); }

}  // namespace loopd
