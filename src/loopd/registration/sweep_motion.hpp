#pragma once
/// @file The sensor's motion over one sweep, measured with the scans themselves: GICP of a sweep onto the one before
/// it, both motion-compensated under the motion being estimated (constant velocity over the two sweeps, the motion
/// model of KISS-ICP's deskew, Vizzo et al. 2023 Sec. III-A), a few rounds. Odometry whose 10 Hz increments carry
/// step noise (wheel slip, a degraded stretch) bends every deskewed scan by that noise; the scans' own overlap
/// measures the increment to millimetres.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/registration/gicp.hpp"
#include "loopd/registration/sweep_bend.hpp"
#include "loopd/registration/sweep_shape.hpp"

namespace loopd {

/// @brief Settings of estimate_sweep_motion.
struct SweepMotionConfig {
  double voxel_size = 1.0;  ///< [m] both sweeps are reduced to voxel centroids (with their mean point time)
  double min_range = 2.0;   ///< [m] points nearer than this (the vehicle, the operator) are left out
  double max_range = 60.0;  ///< [m] and farther than this (sparse, where a rotation error weighs most)
  /// Input points used (a deterministic stride beyond it; 0: all): a 1 m voxel's plane needs a few dozen returns, not
  /// the hundreds an HDL-64E puts into one nearby.
  int max_input_points = 60000;
  /// A voxel's points form a plane (its GICP normal) when their smallest scatter eigenvalue is below this share of the
  /// middle one; otherwise the voxel gets none (isotropic covariance).
  double max_plane_thickness = 0.1;
  int rounds = 1;  ///< deskew under the estimate, register; more rounds re-deskew under the new estimate
  /// A refined increment farther than this from the odometry's is not believed (a repetitive scene, a failed
  /// registration): the odometry's is kept. [m] / [deg].
  double max_translation_change = 0.5;
  double max_rotation_change_deg = 3.0;
  double min_fitness = 0.5;
  /// Above this translational condition number of the registration (gicp_degeneracy) the translation along its
  /// weakest direction is the odometry's (across it, and the rotation, the scans'): a tunnel, or a straight street
  /// seen by few rings, does not fix where along it the sensor went.
  double max_degeneracy = 10.0;
  /// The previous sweep is deskewed at the velocity being estimated unless the odometry's rotations over the two
  /// sweeps differ by more than this (a turn's onset or end); then at that velocity with the odometry's rotation over
  /// the previous sweep. Only the rotation: the odometry's translation steps are noisier than a vehicle's change of
  /// speed in 0.1 s, and a rotation error weighs by the range. [deg] per sweep.
  double min_velocity_change_deg = 0.5;
  GicpConfig gicp = default_gicp();
  /// After the constant-velocity estimate, the current sweep's rotation is refined with more than one turn rate
  /// (refine_sweep_shape against the previous sweep), where the registration is not degenerate, shape.segments > 0 and
  /// the odometry's turn rate changed between the sweeps by more than shape.min_rate_change_deg.
  SweepShapeConfig shape;

  /// @brief GICP at 1 m voxels: 1.0 / 0.5 m correspondence stages, 1500 source points, one thread (the keyframe
  ///        workers already run in parallel).
  static GicpConfig default_gicp();
  std::optional<std::string> validate() const;
};

/// @brief A motion over one sweep: the pose at its end in the frame of its start, and the time between them.
struct SweepIncrement {
  Eigen::Isometry3d T_start_end = Eigen::Isometry3d::Identity();
  double dt = 0.0;  ///< [s]
};

/// @brief What a gyro says of the two sweeps: their bends off their constant-velocity paths (empty: none) and rotations.
struct SweepBends {
  SweepBend previous, current;
  /// The previous sweep's rotation measured by a gyro: the previous sweep is deskewed at it (and at the translation's
  /// constant velocity) whatever the odometry's rotations say.
  std::optional<Eigen::Matrix3d> previous_rotation;
  /// The current sweep's rotation measured by the gyro: the first estimate's rotation (the odometry's translation), so
  /// that both sweeps are first deskewed alike; the registration then measures the increment.
  std::optional<Eigen::Matrix3d> current_rotation;
};

/// @brief What estimate_sweep_motion found.
struct SweepMotionResult {
  bool refined = false;  ///< T_previous_current is the scans' (otherwise the odometry's, and `reason` says why)
  Eigen::Isometry3d T_previous_current = Eigen::Isometry3d::Identity();  ///< sensor at the current stamp in the previous stamp's frame
  double translation_change = 0.0;                                       ///< [m] from the odometry's increment
  double rotation_change_deg = 0.0;                                      ///< [deg]
  double fitness = 0.0;
  /// Degenerate registration (degeneracy above max_degeneracy): the translation along `weak_direction` is the
  /// odometry's, across it the scans'.
  bool weak_direction_from_odometry = false;
  Eigen::Vector3d weak_direction = Eigen::Vector3d::Zero();  ///< unit, in the previous stamp's frame (when the above)
  bool translation_from_odometry = false;                    ///< degenerate without a usable direction: all of it
  bool velocity_changed = false;                             ///< the previous sweep was deskewed at its own velocity (the odometry's changed)
  bool bent = false;         ///< the current sweep's path is the scans' increment bent as the gyro turned (bends.current)
  double degeneracy = -1.0;  ///< gicp_degeneracy of the last registration (large: a direction the scans do not fix)
  int iterations = 0;        ///< GICP iterations over all rounds
  /// The path through the current sweep with more than one turn rate (refine_sweep_shape), when shape_refined:
  /// knot times [s] relative to the current stamp and the sensor's pose there in the previous stamp's frame.
  bool shape_refined = false;
  std::vector<double> knot_times;
  std::vector<Eigen::Isometry3d> T_previous_knot;
  double shape_correction_deg = 0.0;  ///< largest rotation of a knot off the constant-velocity path
  double ms = 0.0;
  std::string reason;
};

/// @brief The points (with their times) of `cloud` that estimate_sweep_motion reads: every stride-th, at most
///        max_input_points. A scan kept only as the next sweep's reference needs no more than this.
PointCloud sweep_motion_input(const PointCloud& cloud, const SweepMotionConfig& config);

/// @brief The motion between two consecutive sweeps' stamps, measured by registering `current` onto `previous`, each
///        deskewed as if the sensor moved at the constant velocity of that motion, on the path deskew() interpolates
///        between the two stamps' poses: at tau [s] after the previous stamp it was at interpolate(I, T_previous_current,
///        tau / dt) in the previous stamp's frame, for the points of both sweeps (PointCloud::time [s] relative to their
///        own scan's stamp). Both clouds need per-point times.
/// @param dt [s] from the previous stamp to the current one (> 0)
/// @param odometry_T_previous_current the odometry's increment: the first estimate and the check on the result
/// @param odometry_previous_sweep the odometry's increment over the previous sweep, when known: where it differs from
///        odometry_T_previous_current in rotation (min_velocity_change_deg), the previous sweep turned at its rate
/// @param bends where a gyro turned through a sweep, its path there is the constant-velocity one bent as the gyro's
///        (SweepBend): the increment is the scans', the shape within the sweep the gyro's, and the current sweep's shape
///        is not refined (refine_sweep_shape) when it has a bend
SweepMotionResult estimate_sweep_motion(const PointCloud& previous, const PointCloud& current, double dt,
                                        const Eigen::Isometry3d& odometry_T_previous_current, const SweepMotionConfig& config,
                                        const std::optional<SweepIncrement>& odometry_previous_sweep = std::nullopt, const SweepBends& bends = {});

}  // namespace loopd
