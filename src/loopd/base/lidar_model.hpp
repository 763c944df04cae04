#pragma once
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief Geometry and noise of a spinning multi-beam lidar.
///
/// Rings are ordered by elevation: ring 0 is the lowest beam, vertical_angles_deg is ascending.
/// A full revolution is sampled at `azimuth_steps` equally spaced columns.
struct LidarModel {
  /// How the beams sweep the field of view. kSpinning: rings x columns (every lidar above but the Livox ones).
  /// kRosette (Livox Avia-like): the lasers trace a rosette over a forward cone, never the same path twice.
  /// kSpinningNonRepetitive (Livox MID-360-like): a full turn of azimuth with each laser's elevation sweeping its band
  /// back and forth, never the same path twice. For the two patterns num_rings is the number of lasers,
  /// vertical_angles_deg the field of view's lowest and highest elevation (2 entries) and azimuth_steps the returns of
  /// one laser in one scan; such a model has no ring structure to build a range image from (loopd reads the scans).
  enum class ScanPattern { kSpinning, kRosette, kSpinningNonRepetitive };
  ScanPattern pattern = ScanPattern::kSpinning;
  double horizontal_fov_deg = 360.0;        ///< [deg] kRosette: the cone's horizontal width (its height: vertical_angles_deg)
  std::string name;                         ///< short name ("vlp16", "hdl32", "hdl64", "os1-64")
  int num_rings = 0;                        ///< number of laser beams
  std::vector<double> vertical_angles_deg;  ///< [deg] elevation of each ring, ascending, ring 0 lowest
  int azimuth_steps = 0;                    ///< columns per revolution (360 deg / horizontal resolution)
  double min_range = 0.0;                   ///< [m] closer returns are not reported
  double max_range = 0.0;                   ///< [m] farther surfaces give no return
  double range_noise_sigma = 0.0;           ///< [m] 1-sigma Gaussian range noise
  double dropout_rate = 0.0;                ///< probability that a ray with a valid hit returns nothing

  /// @brief Horizontal resolution [deg].
  double azimuth_step_deg() const { return azimuth_steps > 0 ? 360.0 / azimuth_steps : 0.0; }
  /// @brief Rays per revolution (num_rings * azimuth_steps).
  int rays_per_scan() const { return num_rings * azimuth_steps; }
  /// @brief nullopt when the model is consistent, else what is wrong.
  std::optional<std::string> validate() const;
};

/// @brief Velodyne VLP-16 (Puck): 16 rings at -15..+15 deg (2 deg step), 0.2 deg at 10 Hz, 100 m, +-3 cm.
LidarModel lidar_model_vlp16();
/// @brief Velodyne HDL-32E: 32 rings at -30.67..+10.67 deg (4/3 deg step), ~0.166 deg at 10 Hz, 100 m, +-2 cm.
LidarModel lidar_model_hdl32();
/// @brief Velodyne HDL-64E (S2/S3, the KITTI sensor): 64 rings -24.9..+2.0 deg in two blocks, 0.1728 deg at 10 Hz, 120 m.
LidarModel lidar_model_hdl64();
/// @brief Ouster OS1-64 (gen 1): 64 rings uniformly over -16.6..+16.6 deg, 2048 columns (10 Hz mode), 120 m.
LidarModel lidar_model_os1_64();
/// @brief Ouster OS1-64 in 1024-column mode (also 10 Hz).
LidarModel lidar_model_os1_64_1024();

/// @brief Ouster Rev6/7 with uniform beams: generation_fov_index 0 = OS0 (90 deg), 1 = OS1 (45 deg), 2 = OS2
/// (22.5 deg); beams 32, 64 or 128; 1024 columns. Named "os0-64", "os1-128", ...; the OS1-64 is "os1-64-rev6".
LidarModel lidar_model_ouster(int generation_fov_index, int beams);
/// @brief Velodyne VLP-32C (Ultra Puck): 32 beams -25..+15 deg from the manual's table, 1800 columns, 200 m.
LidarModel lidar_model_vlp32c();
/// @brief Velodyne VLS-128 (Alpha Prime): 128 beams -25..+15 deg, 0.11 deg near the horizon (approximated), 1800 columns.
LidarModel lidar_model_vls128();
/// @brief Hesai Pandar64: 64 beams -25..+15 deg, 0.167 deg between -6 and +2 deg (approximated), 1800 columns.
LidarModel lidar_model_pandar64();
/// @brief Hesai PandarXT-32: 32 beams -16..+15 deg at 1 deg, 2000 columns.
LidarModel lidar_model_pandar_xt32();

/// @brief Livox Avia-like (datasheet: 70.4 x 77.2 deg non-repetitive rosette, 6 lasers, 240k points/s: 24,000 a
/// scan at 10 Hz, 450 m at 80 % reflectivity, 2 cm): a pattern model (LidarModel::ScanPattern::kRosette).
LidarModel lidar_model_avia();
/// @brief Livox MID-360-like (datasheet: 360 x 59 deg, -7..+52 deg, non-repetitive, 200k points/s: 20,000 a scan at
/// 10 Hz, 40 m at 10 % reflectivity, 0.1-70 m, 2 cm): a pattern model (kSpinningNonRepetitive, 4 lasers).
LidarModel lidar_model_mid360();
/// @brief The non-repetitive solid-state models: "avia", "mid360" (lidar_model_from_name knows them too).
std::vector<std::string> lidar_pattern_model_names();

/// @brief Model by name (lidar_model_names() and lidar_pattern_model_names()); nullopt if unknown. "auto" is not a model: see sensor_estimate.hpp.
std::optional<LidarModel> lidar_model_from_name(const std::string& name);
/// @brief Names accepted by lidar_model_from_name.
std::vector<std::string> lidar_model_names();

/// @brief Ring whose elevation is nearest to `elevation_rad`; -1 if the elevation lies outside the model's
/// fan by more than half the neighbouring ring spacing (or the model has no rings).
int ring_from_elevation(const LidarModel& model, double elevation_rad);

}  // namespace loopd
