#pragma once
/// @file The corrected 3D map (Ren 2019 Sec. 3.5): every keyframe's map cloud moved into the map frame by its
/// (corrected) pose and merged through the occupancy octree, then cleaned. Two passes over the keyframes, one map
/// cloud in memory at a time:
///  1. ray-cast each cloud into the octree from its sensor origin (free space seen later clears what moved);
///  2. move each cloud again, drop the points whose leaf ended free, and merge the rest into a voxel grid (centroid,
///     mean intensity);
/// then the roadway-section noise filter along the trajectory (tunnel sections) and a statistical outlier filter
/// for the points no tunnel section covered. Memory: the octree plus the map at its voxel size, not the keyframes.
/// Built again from the store whenever it is asked for, so it always follows the newest correction.
#include <Eigen/Geometry>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "loopd/map3d/occupancy_map.hpp"
#include "loopd/map3d/roadway_noise.hpp"
#include "loopd/map3d/statistical_outliers.hpp"

namespace loopd {

/// @brief What build_map does, stage by stage.
struct MapBuildConfig {
  OccupancyMapConfig octree;
  double voxel = 0.2;                ///< [m] leaf of the output map (centroids, mean intensity)
  bool clear_free_space = true;      ///< drop points whose octree leaf ended free (moving objects)
  bool roadway_noise = true;         ///< Ren 2019 Sec. 3.5 roadway-section filter along the trajectory
  bool statistical_outliers = true;  ///< outlier filter for the points outside tunnel sections
  RoadwayNoiseConfig roadway;
  StatisticalOutlierConfig outliers;
  std::optional<std::string> validate() const;
};

/// @brief One keyframe of the map: its key and its pose in the map frame (corrected, or odometry for comparison).
struct MapBuildKeyframe {
  KeyframeKey key;
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
};

/// @brief The keyframe's map cloud (sensor frame), or nullopt when it has none (a keyframe shed under load, a map
/// written before map clouds): left out and counted.
using MapCloudSource = std::function<std::optional<PointCloud>(const KeyframeKey&)>;

/// @brief Called with (phase, done, total) as keyframes are processed: phase "octree" then "merge".
using MapBuildProgress = std::function<void(const char* phase, std::size_t done, std::size_t total)>;

/// @brief What each stage did.
struct MapBuildStats {
  std::size_t keyframes = 0, keyframes_without_cloud = 0;
  std::size_t points_in = 0;         ///< map-cloud points read (both passes see the same)
  std::size_t points_cleared = 0;    ///< dropped in pass 2: their leaf ended free
  std::size_t points_merged = 0;     ///< voxels after the merge
  std::size_t roadway_removed = 0;   ///< voxels the roadway filter removed
  std::size_t outliers_removed = 0;  ///< voxels the statistical filter removed
  std::size_t points_out = 0;
  RoadwayNoiseResult roadway;  ///< station counts (remove / in_tunnel masks cleared)
  std::size_t octree_leaves = 0, octree_bytes = 0;
  double seconds_octree = 0.0, seconds_merge = 0.0, seconds_filter = 0.0;
};

struct MapBuildResult {
  PointCloud map;  ///< map frame, sorted by voxel
  MapBuildStats stats;
};

/// @brief Pass 1 only: the occupancy octree of the keyframes (export-octomap); counts into `stats`.
void insert_keyframes(const std::vector<MapBuildKeyframe>& keyframes, const MapCloudSource& clouds, const MapBuildProgress& progress,
                      OccupancyMap* octree, MapBuildStats* stats);

/// @brief The whole map (config validated by the caller).
MapBuildResult build_map(const std::vector<MapBuildKeyframe>& keyframes, const MapCloudSource& clouds, const MapBuildConfig& config,
                         const MapBuildProgress& progress = {});

}  // namespace loopd
