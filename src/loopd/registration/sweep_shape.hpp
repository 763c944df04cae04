#pragma once
/// @file The sensor's rotation through one sweep, with more than one turn rate: a sweep registered onto a reference
/// (the sweep before it, already motion-compensated) under a path that is the constant-velocity one times a rotation
/// correction that varies linearly between `segments` + 1 knots spread over the sweep's times. A turn's onset or end
/// inside a sweep (the turn rate steps within 0.1 s) bends a constant-velocity deskew by up to a quarter of the sweep's
/// rotation change; each part of a spinning lidar's sweep (a half, with the two segments loopd uses when it is on) sees
/// its own part of the scene, and that part fixes its own rotation. The continuous-time idea is CT-ICP's (Dellenbach et al. 2022, Sec. III: poses at
/// a scan's begin and end), here with rotation-only knots inside the sweep: a vehicle's speed cannot change in 0.1 s, its turn rate can, and a
/// rotation error moves a point by its range.
#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief Settings of refine_sweep_shape.
struct SweepShapeConfig {
  int segments = 2;  ///< knots = segments + 1, evenly over the sweep's times; 0 = off (one rate; 2: a rate per half sweep)
  /// Only the rotation about the sensor's z axis is refined; roll and pitch stay on the constant-velocity path. A ground
  /// vehicle's turn rate steps within 0.1 s (steering), its roll and pitch rates do not, and a half sweep fixes its
  /// heading well (walls at every azimuth) but its tilt poorly: refined in all three axes, the tilt knots took the noise
  /// (the 2000-scan ring drive's loop rotation p95 0.11 -> 0.23 deg; heading only, with the gate below: 0.12). false: a
  /// handheld or legged sensor.
  bool yaw_only = true;
  /// estimate_sweep_motion refines the shape only where the odometry's rotations over the previous sweep and this one
  /// differ by at least this [deg per sweep] (a turn rate that changed between them, so perhaps inside this one):
  /// one rate is right where the rate holds, and two rates there only add noise. The odometry's step noise on
  /// straights is ~0.08 deg per step (median, simulator); without the previous sweep's odometry it is not refined.
  double min_rate_change_deg = 0.25;
  /// Prior on the change of the correction from one knot to the next [deg]: lets a knot follow its own data where
  /// that data fixes it and holds it to its neighbours where it does not (a quarter sweep facing open ground).
  double knot_change_sigma_deg = 0.5;
  double plane_sigma = 0.1;         ///< [m] spread of a point about its reference plane (voxel centroids)
  double max_correspondence = 0.5;  ///< [m] nearest reference voxel within this
  int iterations = 6;               ///< Gauss-Newton iterations (correspondences re-found each time)
  int min_points_per_segment = 30;  ///< a segment with fewer planar correspondences leaves the result unrefined
  double max_correction_deg = 2.0;  ///< a knot further from the constant-velocity path than this: not believed
  std::optional<std::string> validate() const;
};

/// @brief What refine_sweep_shape found: the sensor's pose at each knot time, in the reference frame.
struct SweepShapeResult {
  bool refined = false;
  std::vector<double> knot_times;                                 ///< [s] relative to the sweep's own stamp, increasing
  std::vector<Eigen::Isometry3d> T_ref_knot;                      ///< sensor pose at each knot time in the reference frame
  Eigen::Isometry3d T_ref_stamp = Eigen::Isometry3d::Identity();  ///< the refined path at time 0 (the sweep's stamp)
  double max_correction_deg = 0.0;                                ///< largest knot rotation off the constant-velocity path
  int correspondences = 0;
  std::string reason;  ///< why not refined
};

/// @brief Refines the rotation along a sweep's path against a reference.
/// @param points, times the sweep's points in the sensor frame at their own time t [s, relative to its stamp]
/// @param path_T_ref_sensor the constant-velocity path: the sensor's pose at time t in the reference frame
/// @param reference, reference_normals points of the reference in its frame, with plane normals (zero: no plane)
SweepShapeResult refine_sweep_shape(const std::vector<Eigen::Vector3f>& points, const std::vector<float>& times,
                                    const std::function<Eigen::Isometry3d(double)>& path_T_ref_sensor, const std::vector<Eigen::Vector3f>& reference,
                                    const std::vector<Eigen::Vector3f>& reference_normals, const SweepShapeConfig& config);

/// @brief segments + 1 evenly spaced knot times over [first, last].
std::vector<double> sweep_knot_times(double first, double last, int segments);

}  // namespace loopd
