#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/point_cloud.hpp"
#include "loopd/sim/town.hpp"

namespace loopd {

/// @brief What a real spinning lidar does to its scans beyond the model's geometry and noise. Every effect is on by
/// default (loopd-sim's scans; DriveConfig::effects); simulate_scan() uses none() (a static, instantaneous scan).
struct SensorEffects {
  /// Motion skew: the head turns once per sweep, clockwise seen from above (as Velodyne's heads do), starting and ending
  /// behind the sensor (KITTI's sweeps, whose cameras fire when the head faces forward, mid-sweep). Each column is
  /// measured at its own time, from the sensor's pose at that time, and given as a driver gives it: range times the
  /// beam direction, in the sensor frame of that moment (not motion-compensated). Deskewing with PointCloud::time
  /// and the motion brings every point into the sensor frame at the scan's stamp.
  bool motion_skew = true;
  /// Per-point times (PointCloud::time, point_cloud_t.time_offset): each point's measurement time relative to the
  /// scan's stamp, which is the end of the sweep (the ROS velodyne driver's default, timestamp_first_packet false):
  /// from -(1 - 1/columns) / rate to 0. All 0 without motion skew (every point is then measured at the stamp).
  bool point_times = true;
  /// Beam dropouts beyond the model's own (LidarModel::dropout_rate and weak far, dark returns): a return is lost
  /// with probability dropout_rate x (1 + range_gain (r / max_range)^2) x (1 + grazing_gain (1 - |cos incidence|)^2)
  /// x (1 + dark_gain max(0, 0.5 - reflectivity) / 0.5), at most 0.95. The gains are modelling choices, not measured.
  bool dropouts = true;
  double dropout_rate = 0.03;         ///< loss of a near, head-on return from a bright surface
  double dropout_range_gain = 2.0;    ///< x3 at max_range
  double dropout_grazing_gain = 2.0;  ///< x3 at grazing incidence
  double dropout_dark_gain = 1.0;     ///< x2 on a black (absorbing) surface
  /// Vegetation: bushes along the sidewalks (Town::primitives with `vegetation`, absent otherwise) and porous tree
  /// crowns. A ray entering foliage returns from inside it with probability 1 - exp(-density x chord), at a depth
  /// drawn from the same law (Beer-Lambert), or passes through; drawn per scan, so two visits of a bush differ.
  bool vegetation = true;
  double foliage_density = 0.6;  ///< [1/m] extinction coefficient of foliage (modelling choice)

  /// @brief Every effect off: the instantaneous scan of simulate_scan().
  static SensorEffects none();
  /// @brief nullopt when consistent, else what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief T_world_sensor at time offset t [s] from the scan's stamp (t <= 0 during the sweep).
using SensorPoseAt = std::function<Eigen::Isometry3d(double t)>;

/// @brief Time offset [s] from the scan's stamp of column c (azimuth 2 pi c / columns) of a sweep lasting `period`:
/// the column behind the sensor (c = columns / 2) fires first, at -(columns - 1) / columns x period, the one next to
/// it on the other side last, at 0 (clockwise seen from above: behind, left, ahead, right).
double column_time_offset(int column, int columns, double period);

/// @brief Ray-casts one sweep of `model` lasting `period` [s] (1 / rate) along `pose_at` in `town` (objects as on
/// `visit`) with `effects`.
///
/// Every ray (ring r, column c) is intersected analytically with the ground plane and with the primitives of the 2D grid
/// cells it crosses (Amanatides-Woo DDA, stopping at the first cell whose exit lies beyond the nearest hit).
/// Range noise (Gaussian, model.range_noise_sigma), dropouts and foliage come from a hash of (seed, ray), so the result
/// is byte-identical for any `num_threads`. Without effects it is simulate_scan(town, model, pose_at(0), ...), bit for bit.
/// @return points in the sensor frame, column-major order (for each column the rings bottom to top), with intensity
///         (reflectivity times incidence factor, in [0, 1]), ring index, num_rings and (effects.point_times) time.
/// @param seed noise seed; a drive uses a hash of (drive seed, scan index).
/// @param num_threads OpenMP threads (<= 0: OpenMP default).
PointCloud simulate_sweep(const Town& town, const LidarModel& model, const SensorPoseAt& pose_at, double period, const SensorEffects& effects,
                          std::uint64_t seed, int num_threads, int visit = 0);

/// @brief Ray-casts one instantaneous revolution of `model` at T_world_sensor in `town` (objects as on `visit`): the
/// model's noise and dropouts only (SensorEffects::none()), no vegetation.
/// @param seed noise seed; @param num_threads OpenMP threads (<= 0: OpenMP default).
/// @param visit the visit whose movable objects (parked cars) are shown; 0 = original layout.
PointCloud simulate_scan(const Town& town, const LidarModel& model, const Eigen::Isometry3d& T_world_sensor, std::uint64_t seed, int num_threads,
                         int visit = 0);

/// @brief Range [m] of the first surface along a world ray (no noise, no vegetation); +inf when nothing is hit within
/// max_range.
double cast_ray(const Town& town, const Eigen::Vector3d& origin, const Eigen::Vector3d& unit_direction, double max_range, int visit = 0);

}  // namespace loopd
