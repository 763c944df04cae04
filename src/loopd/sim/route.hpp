#pragma once
#include <string>
#include <vector>

#include "loopd/sim/drive.hpp"
#include "loopd/sim/town.hpp"

namespace loopd {

/// @brief Visit labels per lap of every route (a lap is three visits: town's three loops, block's and ring's
/// three rounds, mine's cell loop, long loop and cell loop again).
constexpr int kRouteVisitsPerLap = 3;

/// @brief True for the route names make_drive knows: "town", "block", "ring" (make_town) and "mine" (make_mine).
bool is_route_name(const std::string& route);

/// @brief Dense samples (5 cm apart) of one lap of the driven path of `config.route` through `town`, arc length filled:
/// corners rounded with config.corner_radius, config.lane_lateral to the left of the street centre line (negative =
/// right) in the direction of travel, the lane-offset stretch of the route.
/// @param reversed the lap driven in the opposite direction, from the same first street node: the waypoints in reverse
///        order, still in the right-hand lane of the direction of travel, each edge with the visit label 2 - that of the
///        edge it reverses (labels count up along the lap), without the lane-offset stretch.
std::vector<DrivePathPoint> build_route_path(const Town& town, const DriveConfig& config, bool reversed);

}  // namespace loopd
