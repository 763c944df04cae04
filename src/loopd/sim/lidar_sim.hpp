#pragma once
#include <Eigen/Geometry>
#include <cstdint>

#include "loopd/core/lidar_model.hpp"
#include "loopd/core/point_cloud.hpp"
#include "loopd/sim/town.hpp"

namespace loopd {

/// @brief Ray-casts one revolution of `model` at T_world_sensor in `town` (objects as on `visit`).
///
/// Every ray (ring r, column c) is intersected analytically with the ground plane and with the primitives of the 2D grid
/// cells it crosses (Amanatides-Woo DDA, stopping at the first cell whose exit lies beyond the nearest hit).
/// Range noise (Gaussian, model.range_noise_sigma) and dropouts (model.dropout_rate) come from a hash of (seed, ray),
/// so the result is byte-identical for any `num_threads`.
/// @return points in the sensor frame, column-major order (for each column the rings bottom to top), with intensity
///         (reflectivity times incidence factor, in [0, 1]), ring index and num_rings filled.
/// @param seed noise seed; a drive uses a hash of (drive seed, scan index).
/// @param num_threads OpenMP threads (<= 0: OpenMP default).
/// @param visit the visit whose movable objects (parked cars) are shown; 0 = original layout.
PointCloud simulate_scan(const Town& town, const LidarModel& model, const Eigen::Isometry3d& T_world_sensor, std::uint64_t seed, int num_threads,
                         int visit = 0);

/// @brief Range [m] of the first surface along a world ray (no noise); +inf when nothing is hit within max_range.
double cast_ray(const Town& town, const Eigen::Vector3d& origin, const Eigen::Vector3d& unit_direction, double max_range, int visit = 0);

}  // namespace loopd
