#pragma once
/// @file How far before its end point a ray stops clearing space: a ray that meets a surface at a grazing angle
/// (the ground far ahead, a tunnel wall along the roadway) runs through that surface's own octree leaves for metres
/// before it ends, and clearing them would eat the surface (OctoMap's insertPointCloud does). The margin grows
/// with the grazing: resolution x (1 + k / max(|cos incidence|, c_min)), the incidence from the point's normal.
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

struct RayMarginConfig {
  int neighbours = 10;       ///< points of the normal's PCA (k nearest, sensor frame)
  double gain = 2.0;         ///< k above: at |cos| = 0.1 a ray stops clearing 21 leaves before its end point
  double min_cosine = 0.05;  ///< |cos incidence| floor (a ray parallel to a surface)
};

/// @brief One margin [m] per point of `cloud_sensor` (sensor frame: the ray runs from the origin to the point) for an
/// octree of leaf `resolution`. Points whose neighbourhood gives no normal get the head-on margin.
std::vector<float> ray_stop_margins(const PointCloud& cloud_sensor, double resolution, const RayMarginConfig& config = {});

}  // namespace loopd
