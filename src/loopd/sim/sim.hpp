#pragma once
/// @file Umbrella header of the simulator (loopd_sim).
///
/// Scene helpers for tests (see each header for details):
///  - make_town(seed) / make_town(TownConfig): procedural town (street grid, facades with recesses, walls, trees, poles,
///    parked cars, sloped ground with kerbs); deterministic for a seed.                                  [town.hpp]
///  - make_other_town(seed): a second town built to the same pattern with no structure in common.       [town.hpp]
///  - make_corridor(CorridorConfig): long straight featureless tunnel (GICP degeneracy along x).          [town.hpp]
///  - street_pose(town, i, j, direction, along, lateral) / ground_pose(town, x, y, yaw): sensor poses.   [town.hpp]
///  - simulate_scan(town, model, T_world_sensor, seed, num_threads, visit): an instantaneous scan at any pose; `visit`
///    selects where the movable parked cars stand (0 = original, others: moved or gone).             [lidar_sim.hpp]
///  - simulate_sweep(town, model, pose_at, period, SensorEffects, ...): a sweep with motion skew, per-point times,
///    dropouts and porous vegetation.                                                                [lidar_sim.hpp]
///  - make_drive(DriveConfig): route with revisits, ground truth, drifting odometry with residuals;
///    Drive::simulate(i, num_threads) ray-casts scan i with DriveConfig::effects (all on by default);
///    DriveConfig::session K >= 2: the same town on another day (other start, reversed for even K, own odometry
///    frame), DriveConfig::odometry_reset_at: a restarted odometry.                                       [drive.hpp]
///  - build_route_path(town, config, reversed): one lap of a route's driven path.                        [route.hpp]
#include "loopd/base/lidar_model.hpp"
#include "loopd/sim/drive.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
