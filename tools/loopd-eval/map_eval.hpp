#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "eval_log.hpp"
#include "loopd/eval/evaluation.hpp"
#include "loopd/eval/map_quality.hpp"

namespace loopd::tools {

/// @brief loopd-eval's map options (--map-cloud and the ones that go with it).
struct MapEvalOptions {
  std::string map_cloud;           ///< the map to judge (.pcd / .ply, ground truth's world frame); empty: no map figures
  std::string map_cloud_odometry;  ///< optional: a map built from odometry; empty: built here from the drive's keyframe scans
  std::string movers;              ///< optional: loopd-sim's movers file (JSON)
  double voxel = 0.2;              ///< [m] leaf of the reference map and of the self-built odometry map
  double range = 60.0;             ///< [m] scan points farther than this from the sensor are left out (map.cloud_max_range)
  MapQualityConfig quality;
  bool enabled() const { return !map_cloud.empty(); }
  std::optional<std::string> validate() const;
};

/// @brief Adds --map-cloud, --map-cloud-odometry, --movers, --map-voxel, --map-range and --map-completeness-radius.
void add_map_options(CLI::App& app, MapEvalOptions* options);

/// @brief What the map evaluation measured.
struct MapEvalReport {
  bool ran = false;                          ///< --map-cloud was given
  MapQuality map;                            ///< --map-cloud against the reference
  std::optional<MapQuality> odometry;        ///< the odometry map against the reference (nullopt: none could be built)
  bool odometry_from_file = false;           ///< the odometry map came from --map-cloud-odometry
  bool has_movers = false;                   ///< --movers was given
  std::int64_t mover_boxes = 0;              ///< boxes in the movers file
  std::int64_t reference_points = 0;         ///< voxels of the reference map
  std::int64_t reference_moving_points = 0;  ///< of them inside the grown mover boxes
  std::int64_t reference_scans = 0;          ///< scans in the reference map
  std::int64_t odometry_scans = 0;           ///< keyframe scans in the self-built odometry map
  std::int64_t scans_deskewed = 0;           ///< reference scans deskewed with ground truth
  std::int64_t scans_without_pose = 0;       ///< scans left out: no ground truth (or odometry) at their utime
  std::int64_t scans_malformed = 0;          ///< scans that did not decode
  std::vector<std::string> warnings;
};

/// @brief Reads --map-cloud (and --map-cloud-odometry, --movers), streams the drive logs' scans into the reference
///        map (deskewed with ground truth, at the ground-truth pose of their utime, cropped to --map-range,
///        voxelised at --map-voxel) and, without --map-cloud-odometry, into an odometry map of the corrected
///        trajectory's keyframe scans at their odometry poses; then compares both maps with the reference.
/// @return false (with `*error`) when a file cannot be read or no reference could be built.
bool run_map_eval(const MapEvalOptions& options, const std::vector<std::string>& drives, const EvalChannels& channels, const EvalInput& input,
                  bool quiet, MapEvalReport* report, std::string* error);

/// @brief The "map quality" table (nothing when the evaluation did not run).
void print_map_eval(const MapEvalReport& report);

/// @brief The map keys of the --json object: map_error_m, map_error_p95_m, map_error_odometry_m, map_completeness,
///        map_points, map_moving_points, map_moving_points_share, map_moving_points_odometry_share,
///        reference_moving_points, map_reference_points (null when not measured).
void add_map_json(const MapEvalReport& report, nlohmann::json& j);

}  // namespace loopd::tools
