#pragma once
/// @file The beam paths of non-repetitive solid-state lidars (Livox Avia and MID-360 alike) over one scan.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "loopd/base/lidar_model.hpp"

namespace loopd {

/// @brief One return slot of a pattern scan: its direction in the sensor frame and its time from the scan's stamp.
struct PatternRay {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  ///< unit, sensor frame (x ahead, z up)
  float time = 0.f;                                      ///< [s] from -(1 - 1/n) period (first) to 0 (last)
};

/// @brief The rays of one scan of a pattern model (LidarModel::pattern != kSpinning), laser after laser interleaved in
/// firing order. The scan's place in the endless pattern comes from `seed` (a drive hashes its scan index into it),
/// so no two scans share a path: the pattern never repeats. Empty for a spinning model.
///   kRosette: each laser traces the sum of two counter-rotating circles (a rosette: two prisms turning at
///     incommensurate rates) scaled to the cone horizontal_fov_deg x (vertical_angles_deg[1] - [0]); the lasers sit
///     1.5 deg apart.
///   kSpinningNonRepetitive: azimuth turns once a scan, each laser's elevation sweeps its band as a triangle wave at an
///     incommensurate rate, the lasers 90 deg apart in azimuth and each a quarter of the band apart in phase.
std::vector<PatternRay> pattern_rays(const LidarModel& model, double period, std::uint64_t seed);

}  // namespace loopd
