#pragma once
/// @file How big the place around the sensor is: the scale a handheld walk through rooms and a drive through a
/// city differ by, read from one scan.
#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief [m] How far the sensor sees around it: in each 5 deg of azimuth the farthest horizontal distance of a return
/// at or above the sensor's height (not the ground: walls, facades, trees), and the median of those over the directions
/// that have one. A few metres in rooms, tens of metres in streets. Returns within 1-200 m only; with fewer than 6
/// such directions (a sensor looking down), the median horizontal distance of all returns. 0: no return at all.
double scene_scale(const PointCloud& scan);

}  // namespace loopd
