#include "loopd/map3d/map_builder.hpp"

#include <chrono>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/voxel_accumulator.hpp"
#include "loopd/map3d/point_mask.hpp"
#include "loopd/map3d/ray_margins.hpp"

namespace loopd {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The entries of `mask` whose `remove` is 0 (the mask of the points remove_points keeps).
std::vector<std::uint8_t> kept_entries(const std::vector<std::uint8_t>& mask, const std::vector<std::uint8_t>& remove) {
  std::vector<std::uint8_t> out;
  out.reserve(mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (i >= remove.size() || remove[i] == 0) out.push_back(mask[i]);
  return out;
}

/// Pass 2: every keyframe's cloud in the map frame, points in free leaves dropped, merged into voxels.
PointCloud merge_keyframes(const std::vector<MapBuildKeyframe>& keyframes, const MapCloudSource& clouds, const MapBuildConfig& config,
                           const OccupancyMap* octree, const MapBuildProgress& progress, MapBuildStats* stats) {
  VoxelAccumulator voxels(config.voxel);
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (progress) progress("merge", k, keyframes.size());
    std::optional<PointCloud> cloud = clouds(keyframes[k].key);
    if (!octree) {  // no pass 1 counted them
      stats->keyframes_without_cloud += cloud ? 0 : 1;
      stats->points_in += cloud ? cloud->size() : 0;
    }
    if (!cloud) continue;
    const PointCloud world = transform(*cloud, keyframes[k].T_map_sensor);
    const bool has_i = world.has_intensity();
    const std::vector<std::uint8_t> cleared = octree ? octree->free_points(world) : std::vector<std::uint8_t>(world.size(), 0);
    for (std::size_t i = 0; i < world.size(); ++i) {
      if (cleared[i]) {
        ++stats->points_cleared;
        continue;
      }
      voxels.add(world.points[i], has_i ? world.intensity[i] : 0.0f);
    }
  }
  if (progress) progress("merge", keyframes.size(), keyframes.size());
  return std::move(voxels).cloud();
}

/// The roadway-section filter, then the statistical filter on what no tunnel section covered.
PointCloud clean_map(PointCloud map, const std::vector<MapBuildKeyframe>& keyframes, const MapBuildConfig& config, MapBuildStats* stats) {
  std::vector<std::uint8_t> in_tunnel;
  if (config.roadway_noise) {
    std::vector<Eigen::Isometry3d> track;
    track.reserve(keyframes.size());
    for (const MapBuildKeyframe& k : keyframes) track.push_back(k.T_map_sensor);
    RoadwayNoiseResult roadway = find_roadway_noise(map, track, config.roadway);
    stats->roadway_removed = roadway.removed;
    in_tunnel = kept_entries(roadway.in_tunnel, roadway.remove);
    map = remove_points(map, roadway.remove);
    roadway.remove.clear();
    roadway.in_tunnel.clear();
    stats->roadway = std::move(roadway);
  }
  if (config.statistical_outliers && map.size() > static_cast<std::size_t>(config.outliers.neighbours)) {
    const std::vector<std::uint8_t> outliers = find_statistical_outliers(map, config.outliers, in_tunnel.empty() ? nullptr : &in_tunnel);
    for (std::uint8_t o : outliers) stats->outliers_removed += o;
    map = remove_points(map, outliers);
  }
  return map;
}

}  // namespace

std::optional<std::string> MapBuildConfig::validate() const {
  if (auto e = octree.validate()) return e;
  if (!(voxel >= 0.02 && voxel <= 5.0)) return "map voxel must be in [0.02, 5] m";
  if (auto e = roadway.validate()) return e;
  if (outliers.neighbours < 1 || !(outliers.std_ratio > 0.0)) return "statistical outliers: need neighbours >= 1 and std_ratio > 0";
  return std::nullopt;
}

void insert_keyframes(const std::vector<MapBuildKeyframe>& keyframes, const MapCloudSource& clouds, const MapBuildProgress& progress,
                      OccupancyMap* octree, MapBuildStats* stats) {
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (progress) progress("octree", k, keyframes.size());
    ++stats->keyframes;
    std::optional<PointCloud> cloud = clouds(keyframes[k].key);
    if (!cloud) {
      ++stats->keyframes_without_cloud;
      continue;
    }
    stats->points_in += cloud->size();
    const std::vector<float> margins = ray_stop_margins(*cloud, octree->resolution());
    octree->insert_scan(transform(*cloud, keyframes[k].T_map_sensor), keyframes[k].T_map_sensor.translation(), margins);
  }
  if (progress) progress("octree", keyframes.size(), keyframes.size());
  stats->octree_leaves = octree->leaves();
  stats->octree_bytes = octree->memory_bytes();
}

MapBuildResult build_map(const std::vector<MapBuildKeyframe>& keyframes, const MapCloudSource& clouds, const MapBuildConfig& config,
                         const MapBuildProgress& progress) {
  MapBuildResult out;
  std::optional<OccupancyMap> octree;
  auto t0 = std::chrono::steady_clock::now();
  if (config.clear_free_space) {
    octree.emplace(config.octree);
    insert_keyframes(keyframes, clouds, progress, &*octree, &out.stats);
  } else {
    out.stats.keyframes = keyframes.size();
  }
  out.stats.seconds_octree = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  PointCloud merged = merge_keyframes(keyframes, clouds, config, octree ? &*octree : nullptr, progress, &out.stats);
  octree.reset();  // its memory back before the filters
  out.stats.points_merged = merged.size();
  out.stats.seconds_merge = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  out.map = clean_map(std::move(merged), keyframes, config, &out.stats);
  out.stats.points_out = out.map.size();
  out.stats.seconds_filter = seconds_since(t0);
  return out;
}

}  // namespace loopd
