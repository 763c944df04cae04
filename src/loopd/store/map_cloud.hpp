#pragma once
/// @file A keyframe's map cloud: the finer cloud the 3D map is built from (Ren 2019 Sec. 3.5), next to the 0.6 m
/// verification cloud. Made on a worker from the deskewed scan, stored compressed in the map store, read back by
/// map building (src/loopd/map3d). Sensor frame, intensity kept.
#include <optional>
#include <string>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief How a keyframe's scan becomes its map cloud, and how finely it is stored.
struct MapCloudConfig {
  bool enabled = true;      ///< keep map clouds in the map store (only when a map store is open)
  double voxel = 0.15;      ///< [m] voxel leaf: the centroid (and mean intensity) of each voxel's points
  double min_range = 1.0;   ///< [m] nearer returns (the vehicle itself) are dropped
  double max_range = 60.0;  ///< [m] farther returns are dropped (sparse, and the first to be wrong after a small rotation error)
  double quantum = 0.01;    ///< [m] coordinate step of the stored form (round-trip error <= quantum / 2 per axis)
  int zstd_level = 3;
  std::optional<std::string> validate() const;
};

/// @brief The map cloud of one (deskewed) scan: non-finite points removed, cropped to [min_range, max_range], voxel
/// centroids at `voxel` (intensity averaged). Keeps no per-point time or ring.
PointCloud reduce_to_map_cloud(const PointCloud& scan, const MapCloudConfig& config);

}  // namespace loopd
