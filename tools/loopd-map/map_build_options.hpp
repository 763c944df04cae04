#pragma once
/// @file What the map-building commands (export-cloud, export-octomap, picture) are told, and the build they share.
#include <optional>
#include <string>

#include "loopd/map3d/map_builder.hpp"
#include "map_poses.hpp"

namespace loopd::tools {

/// @brief Options of export-cloud, export-octomap and picture.
struct MapBuildOptions {
  std::string out;
  double voxel = 0.2;  ///< [m] output map voxel
  std::optional<std::int64_t> session;
  bool odometry = false;                   ///< uncorrected poses (for comparison)
  bool keep_moving = false;                ///< no free-space clearing
  bool keep_roadway_noise = false;         ///< no roadway-section filter
  bool keep_outliers = false;              ///< no statistical filter
  double resolution = 0.2;                 ///< [m] octree leaf
  double ray_range = 30.0;                 ///< [m] ray-casting range
  double prob_hit = 0.7, prob_miss = 0.4;  ///< OctoMap's sensor model (its defaults)
  double picture_cell = 0.0;               ///< [m] picture pixel (0: fit the map in about 1400 pixels)
  std::string picture_cloud;               ///< picture: draw this exported map (.pcd / .ply) instead of building one
};

/// @brief The build configuration the options ask for.
MapBuildConfig build_config(const MapBuildOptions& options);

/// @brief What a build needs: the configuration the options ask for (validated) and the keyframes' poses; false after
/// printing why not.
bool prepare_build(MapStore& store, const MapBuildOptions& options, bool progress, MapBuildConfig* config, KeyframePoses* poses,
                   std::vector<MapBuildKeyframe>* keyframes);

/// @brief The keyframes' map clouds from the store (a keyframe without one, or an unreadable one, is left out; the
/// first unreadable one is kept in *error).
MapCloudSource store_clouds(MapStore& store, std::string* error);

/// @brief A progress callback drawing one bar per build phase on stderr.
MapBuildProgress phase_progress(bool enabled);

}  // namespace loopd::tools
