#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

namespace loopd {

/// @brief Settings of a simulated drive through make_town(seed) (make_mine(seed) for the route "mine").
///
/// The route (street nodes (i, j), block ~50-75 m) repeats every lap; a lap has three visits:
///  - visit 0, short loop around one block: (0,0) E (1,0) N (1,1) W (0,1) S (0,0)  (~250 m);
///  - visit 1, long loop: (0,0) E (1,0) E (2,0) N (2,2) W (0,2) S (0,0) (~500 m); the first half of (0,0)->(1,0) is driven
///    3 m to the left of the usual lane (lane offset), its second half and (0,1)->(0,0) are same-direction revisits;
///  - visit 2, turn-around via (0,-1) E (1,-1) N (1,0), then the block of visit 0 in the opposite direction:
///    (1,0) W (0,0) N (0,1) E (1,1) S (1,0), back via S (1,-1) W (0,-1) N (0,0) (~620 m).
/// A 1000-scan drive at 1 m per scan covers visits 0, 1 and the first opposite-direction edge; a lap is ~1.37 km.
/// Parked cars marked movable change state with the visit (later laps continue counting visits: lap * 3 + v).
///
/// Sessions (multi-session mapping: the same town driven again on another day). Session 1 is the drive above. Session
/// K >= 2 drives the same town (make_town(seed): same buildings, poles, trees and static parked cars) and the same lap,
/// but:
///  - even K drive the lap in the opposite direction (its waypoints reversed, in the right-hand lane of that direction,
///    without the lane-offset stretch); odd K in the same direction;
///  - it starts start_offset metres into its lap: lap length * hash_uniform(seed, K, attempt) for the first attempt
///    (0, 1, ...) whose start is more than 50 m from session 1's first pose or heads more than 90 deg away from it;
///  - its own odometry noise and drift (seeded by (seed, K)) and its own odometry frame: odometry starts at identity
///    at its first scan, while ground truth stays in session 1's world frame;
///  - its own scan noise and vegetation (scan seeds hashed with K) and parked-car states (cars on visit v show the
///    state of visit v + (K - 1) * 2^20: the movable cars moved between sessions);
///  - its scans start (K - 1) days after start_utime (at start_utime with same_day).
/// odometry_reset_at = N (any session) restarts the odometry at scan N as a restarted odometry process would:
/// T_odom_sensor(N) = I, drift from there; ground truth, noise draws and every other scan's step are unchanged.
struct DriveConfig {
  std::string sensor = "hdl64";  ///< lidar model name (lidar_model_from_name)
  /// Route: "town" (the three-visit lap above), "block" (the short block loop driven again and again in the same
  /// direction, cars changing with every lap, the third lap starting in the lane-offset position: many revisits in
  /// few scans, for end-to-end tests and the demo) or "ring" (the streets two blocks in from the town's edges, ~1.5 km
  /// a round, driven round after round counter-clockwise: first revisit after a whole round, for large-drift tests)
  /// or "mine" (through make_mine(seed) instead of the town: the roadway cell (0..1, 0..1), the long loop
  /// (0..2, 0..1) with same-direction revisits of whole roadways, the cell again; ~0.9-1.3 km a lap, no U-turns). The
  /// mine route has its own defaults, applied by make_drive where the config still holds the town's: lane_lateral 0
  /// (the roadway centre line) instead of -2 m, corner_radius 3 m instead of 9 m, speed 5 m/s instead of 10;
  /// Drive::config holds the values used.
  std::string route = "town";
  int num_scans = 1000;
  std::uint64_t seed = 1;                       ///< town, noise and odometry drift seed
  double speed = 10.0;                          ///< [m/s]
  double rate_hz = 10.0;                        ///< scan rate [Hz]
  double sensor_height = 1.8;                   ///< [m] above the ground
  double lane_lateral = -2.0;                   ///< [m] usual lane: left of the street centre line (negative = right)
  double lane_offset = 3.0;                     ///< [m] extra lateral offset on the lane-offset stretch
  double corner_radius = 9.0;                   ///< [m] corner rounding at intersections
  std::int64_t start_utime = 1700000000000000;  ///< [us] session 1's first scan; session K's is (K - 1) days later
  int session = 1;                              ///< 1 = the reference drive; >= 2: another day's drive (above), <= 1000
  bool same_day = false;                        ///< session K's scans start at start_utime too (two vehicles of one hour)
  std::optional<int> odometry_reset_at;         ///< scan in [1, num_scans) where the odometry restarts from identity
  // Odometry drift (applied to ground-truth increments).
  double heading_bias_deg_per_100m = 0.5;  ///< systematic yaw drift [deg / 100 m]
  double scale_bias = 0.01;                ///< systematic scale error of translation (1 %)
  double yaw_random_walk_deg = 0.02;       ///< [deg] yaw error per step (heading random walk: sigma grows with sqrt(steps))
  double translation_noise = 0.01;         ///< [m] white translation noise per step (each axis)
  double pitch_roll_noise_deg = 0.005;     ///< [deg] white pitch / roll noise per step
  double burst_probability = 0.01;         ///< chance per step that a degraded stretch starts
  int burst_length = 20;                   ///< [steps] length of a degraded stretch
  double burst_factor = 10.0;              ///< noise multiplier inside a degraded stretch
  double base_residual = 0.03;             ///< [m] residual of a clean odometry step
  /// Motion skew, dropouts, vegetation and per-point times (all on; SensorEffects::none() for instantaneous scans).
  /// The sweep lasts 1 / rate_hz: 0.1 s at 10 Hz, the rate of KITTI's HDL-64E (Geiger et al. 2013; the VLP-16 turns at
  /// 5-20 Hz, the HDL-64E S2 at 5-15 Hz, per their datasheets).
  SensorEffects effects;
  std::optional<std::string> validate() const;
};

/// @brief One scan of a drive.
struct DriveScan {
  int index = 0;
  std::int64_t utime = 0;                                            ///< [us] stamp: the end of the sweep
  Eigen::Isometry3d T_world_sensor = Eigen::Isometry3d::Identity();  ///< ground truth at utime
  /// Drifting odometry: session 1 starts at the ground truth, session K >= 2 and an odometry reset at identity;
  /// residual [m] of the step ending here.
  StampedPose odometry;
  int odometry_segment = 0;     ///< 0, then 1 from DriveConfig::odometry_reset_at on (a new odometry frame)
  int visit = 0;                ///< visit counter (the movable cars show visit + Drive::car_visit_offset)
  double route_distance = 0.0;  ///< [m] travelled since the start
  double injected_error = 0.0;  ///< [m] random drift injected on the step ending here (translation + 10 m * yaw)
  bool degraded = false;        ///< inside a degraded (burst) stretch
};

/// @brief A sample of the driven path of one lap.
struct DrivePathPoint {
  Eigen::Vector2d p = Eigen::Vector2d::Zero();  ///< [m] planar position
  int visit = 0;                                ///< visit label within the lap
  double s = 0.0;                               ///< [m] arc length from the lap's start
};

/// @brief A drive: town, lidar model and per-scan poses. Scans are simulated on demand.
struct Drive {
  DriveConfig config;  ///< as given, with the route's defaults applied (DriveConfig::route)
  LidarModel model;
  Town town;
  std::vector<DriveScan> scans;
  double lap_length = 0.0;           ///< [m] route length of one lap
  std::vector<DrivePathPoint> path;  ///< one lap of the driven path (lane offsets applied), 5 cm apart
  std::string error;                 ///< non-empty when the config was invalid (scans empty)
  bool reversed = false;             ///< the lap is driven in the opposite direction (even sessions)
  double start_offset = 0.0;         ///< [m] where in its lap scan 0 is (0 for session 1)
  int car_visit_offset = 0;          ///< added to a scan's visit for the parked cars' states: (session - 1) * 2^20

  /// @brief Ray-casts scan i (noise seed scan_seed(i), cars as on visit scans[i].visit + car_visit_offset) with config.effects: with
  /// motion skew, its sweep follows the route from scans[i].route_distance - speed / rate_hz to scans[i].route_distance.
  PointCloud simulate(int i, int num_threads) const;
  /// @brief Ground-truth sensor pose after `route_distance` [m] of the drive (any real number: laps repeat; from
  /// start_offset into the lap); the pose of
  /// scans[i] is pose_at_distance(scans[i].route_distance).
  Eigen::Isometry3d pose_at_distance(double route_distance) const;
  /// @brief Seed of scan i's noise: hash(config.seed, i), hashed with config.session for sessions >= 2.
  std::uint64_t scan_seed(int i) const;
  /// @brief Route distance covered [m].
  double route_length() const { return scans.empty() ? 0.0 : scans.back().route_distance; }
  /// @brief Number of distinct visits (max visit + 1).
  int num_visits() const;
  /// @brief Count of scans that have a ground-truth partner closer than `radius` [m] at least `min_gap` scans earlier.
  int count_revisits(double radius = 1.0, int min_gap = 100) const;
};

/// @brief Builds the route, ground truth and drifting odometry for `config`. Deterministic for config.seed and
/// config.session; session 1 without odometry_reset_at is the drive of before sessions, bit for bit.
Drive make_drive(const DriveConfig& config);

}  // namespace loopd
