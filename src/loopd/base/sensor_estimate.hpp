#pragma once
/// @file The lidar's ring structure read from a scan: `--sensor auto`.
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Settings of estimate_sensor.
struct SensorEstimateConfig {
  double min_range = 1.0;             ///< [m] closer returns are ignored (the carrier, the operator)
  double max_range = 200.0;           ///< [m] farther returns are ignored
  double ring_min_range = 4.0;        ///< [m] rings are looked for in returns at least this far (a beam's origin offset
                                      ///< from the sensor's centre blurs z / r at close range)
  double bin_deg = 0.04;              ///< [deg] elevation histogram bin
  double ring_mass_fraction = 0.75;   ///< rings are resolved when this share of the returns lie on a peak
  int min_rings = 4;                  ///< fewer peaks: not a multi-beam pattern
  int max_samples = 40000;            ///< elevations looked at (an odd stride over the points beyond it)
  double unstructured_row_deg = 1.4;  ///< [deg] tallest row when no rings resolve (a non-repetitive or voxelised scan)
  double pixel_occupancy = 0.4;       ///< returns per range-image pixel aimed at when no rings resolve

  /// @brief Empty when valid, otherwise what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief What a scan says of the lidar that made it.
struct SensorEstimate {
  bool ok = false;
  std::string error;                ///< why nothing could be estimated (too few returns)
  LidarModel model;                 ///< name "auto": rings (resolved or binned), columns, range limits
  bool rings_from_scan = false;     ///< the scan carries ring indices (the model's elevations are their medians)
  bool rings_resolved = false;      ///< distinct beams were found; false: elevations are binned between the extremes
  double elevation_min_deg = 0;     ///< [deg] 0.5 % quantile of the returns' elevations
  double elevation_max_deg = 0;     ///< [deg] 99.5 % quantile
  double azimuth_coverage_deg = 0;  ///< [deg] part of the circle with returns (360: a spinning lidar)
  std::size_t returns = 0;          ///< finite returns within the range limits

  /// @brief "64 rings between -44.6 and +44.9 deg, 1024 columns" or "no ring pattern: 64 rows over -35.0..+35.0 deg".
  std::string describe() const;
};

/// @brief Reads the ring structure of a scan: from its ring indices when it has them, else from peaks of the
/// returns' elevation histogram (one per beam of a spinning lidar). A scan without distinct beams (a non-repetitive
/// solid-state lidar, a voxelised or merged cloud) gets evenly spaced rows between its elevation extremes, sized so a
/// range-image pixel holds about `pixel_occupancy` returns. Deterministic: a function of the scan alone.
SensorEstimate estimate_sensor(const PointCloud& scan, const SensorEstimateConfig& config = {});

/// @brief Empty when `preset` fits what `scan_estimate` saw; else one sentence saying how they differ, e.g.
/// "scans have 64 rings between -45.0 and +45.0 deg; --sensor os1-64 expects 64 between -16.6 and +16.6".
std::optional<std::string> preset_mismatch(const LidarModel& preset, const SensorEstimate& scan_estimate);

/// @brief The fixed model a sensor choice names: a preset, "custom" built from `elevations_deg` and `columns`, or
/// nullopt for "auto" (and for unknown names: validate_sensor_choice tells those apart).
std::optional<LidarModel> sensor_model_from_choice(const std::string& sensor, const std::vector<double>& elevations_deg = {}, int columns = 1024);
/// @brief Empty when `sensor` is "auto", a preset, or "custom" with a valid table; else what is wrong.
std::optional<std::string> validate_sensor_choice(const std::string& sensor, const std::vector<double>& elevations_deg = {}, int columns = 1024);
/// @brief The model the range image of `scan` uses: `fixed` when given (a preset or custom table), else what the scan
/// shows (estimate_sensor; nullptr when it shows too little). `seen` receives the scan's estimate either way, so a
/// caller can check the preset against it (preset_mismatch).
const LidarModel* model_for_scan(const std::optional<LidarModel>& fixed, const PointCloud& scan, SensorEstimate* seen);
/// @brief "auto, custom, vlp16, vlp32c, ...": every accepted sensor choice, for help texts and errors.
std::string sensor_choices();

}  // namespace loopd
