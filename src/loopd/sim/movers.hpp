#pragma once
/// @file Ground truth of the objects that change during a drive (parked cars in the town, vehicles and equipment in
/// the mine), for map-quality evaluation: a map built from the drive should not keep them (loopd-sim --movers-out).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "loopd/sim/drive.hpp"

namespace loopd {

/// @brief The world-frame axis-aligned bounding box of one state (variant) of a movable object.
struct MoverBox {
  int movable_id = -1;                            ///< Primitive::movable_id
  int variant = 0;                                ///< 0 = where it stood on visit 0, 1 = moved ("gone", 2, has no primitives and no box)
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d max = Eigen::Vector3d::Zero();  ///< [m]
  /// The object no longer stands here at the drive's end (its state on the last scan's visit is another): a map of
  /// the drive should not keep these points. The state shown at the end is part of the final scene.
  bool left = false;
};

/// @brief Every variant with primitives of every movable object whose shown state
/// (Town::active_variant(id, scan.visit + drive.car_visit_offset)) differs between at least two scans of the drive,
/// sorted by (movable_id, variant). Empty when the drive shows one state of everything (e.g. visit 0 only).
std::vector<MoverBox> changing_movers(const Drive& drive);

/// @brief `{"format":"loopd-movers","version":1,"movers":[{"id":3,"variant":0,"min":[x,y,z],"max":[x,y,z],"left":true},...]}`
/// (keys in this order, one line; read by loopd-eval).
std::string movers_json(const std::vector<MoverBox>& movers);

}  // namespace loopd
