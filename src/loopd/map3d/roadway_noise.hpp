#pragma once
/// @file Roadway-section noise removal for the merged 3D map (Ren 2019, Sec. 3.5, Steps 1-4): the map is cut by thin
/// slabs normal to the corrected trajectory; in each slab the section is split into roof, floor and two walls (S1..S4),
/// a curve is fitted to each part (RANSAC, then least squares on its inliers), and where all four are found (an enclosed
/// roadway) the points inside the roadway, off its surfaces, are noise: dust, people, vehicles.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Settings of the roadway-section noise removal (Ren 2019, Sec. 3.5).
struct RoadwayNoiseConfig {
  double section_thickness = 0.4;  ///< [m] delta: a station's band is |n.(p - station)| <= delta / 2 (Ren 2019, Eq. 13)
  double station_spacing = 0.4;    ///< [m] largest distance between stations along a step; = delta: the bands tile the path
  /// [m] thickness of the slab the section curves are fitted to (>= section_thickness; only the delta band is cleaned).
  /// Thicker than delta so that a person-sized object stays a minority of its sector; = delta is Ren's section.
  double fit_thickness = 2.0;
  double max_step = 3.0;                   ///< [m] skip rule (Ren: distance): a longer step between keyframes is not cut
  double max_direction_change_deg = 15.0;  ///< [deg] skip rule (Ren: curvature): angle between a step and the one before
  double max_heading_offset_deg = 20.0;    ///< [deg] skip rule (Ren: heading): angle between a step and its keyframe's x axis
  double section_radius = 8.0;             ///< [m] only points within this distance of the station in the section plane count
  double max_surface_tilt_deg = 30.0;      ///< [deg] a floor line may tilt this far from horizontal, a wall line from vertical
  int ransac_iterations = 100;             ///< RANSAC candidates per sector
  int ransac_max_points = 400;             ///< candidates are scored on at most this many points of a sector (evenly strided)
  double inlier_distance = 0.15;           ///< [m] a point this close to a sector's curve is on the surface
  int min_sector_points = 30;              ///< a sector with fewer points (or inliers) does not count
  double min_inlier_share = 0.6;           ///< a sector counts when at least this share of its points are inliers of its curve
  std::uint32_t seed = 1;                  ///< RANSAC seed; each station draws from its own generator (seed, station)
  int num_threads = 0;                     ///< OpenMP threads over stations (0: OpenMP's default); results do not depend on it

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Outcome of find_roadway_noise. Masks have one entry per map point.
struct RoadwayNoiseResult {
  std::vector<std::uint8_t> remove;     ///< 1: noise inside an enclosed roadway section
  std::vector<std::uint8_t> in_tunnel;  ///< 1: in the delta band of a tunnel station (the statistical filter may skip it)
  int stations = 0;                     ///< sections cut: tunnel_stations + not_enclosed
  int tunnel_stations = 0;              ///< sections with roof, floor and both walls fitted
  int skipped_step = 0;                 ///< steps between keyframes not cut: longer than max_step
  int skipped_curvature = 0;            ///< steps not cut: direction changed more than max_direction_change_deg
  int skipped_heading = 0;              ///< steps not cut: more than max_heading_offset_deg off the keyframe's heading
  int not_enclosed = 0;                 ///< sections cut where a sector did not count (open ground, junction, opening)
  std::size_t removed = 0;              ///< points with remove = 1
  std::string error;                    ///< non-empty when the config was invalid (then nothing is removed)
};

/// @brief Finds roadway noise in a world-frame map along the corrected keyframe trajectory (Ren 2019, Sec. 3.5).
///
/// Each step between consecutive keyframes that passes the three skip rules is cut by stations spaced at most
/// station_spacing apart, with the step direction as section normal (Ren 2019, Eq. 12). The section's 2D frame is
/// u lateral (left), v up (world z projected onto the section plane). A point of the delta band is removed only when
/// it lies on the station's side of all four fitted curves, farther than inlier_distance from each: points behind a
/// surface (a cross-cut, a side roadway at a junction) are kept.
/// @param map_world merged map points [m], world frame
/// @param T_world_keyframe corrected keyframe poses in order (sensor x forward, z up)
/// @note Map points are bucketed in 1 m cells once, so each station reads only the cells its slab crosses.
RoadwayNoiseResult find_roadway_noise(const PointCloud& map_world, const std::vector<Eigen::Isometry3d>& T_world_keyframe,
                                      const RoadwayNoiseConfig& config);

}  // namespace loopd
