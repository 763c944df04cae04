#pragma once
/// @file Scan Context place descriptor (Kim & Kim, "Scan Context: Egocentric Spatial Descriptor for Place Recognition
/// within 3D Point Cloud Map", IROS 2018): the largest height per polar bin (ring x sector) around the sensor, a
/// rotation-invariant ring key for the fast k-NN, and the column-wise cosine distance minimised over sector shifts.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Scan Context parameters (Kim & Kim 2018, Sec. IV-A: N_r = 20, N_s = 60, L_max = 80 m).
struct ScanContextConfig {
  int num_rings = 20;      ///< N_r: rings, equal width max_range / N_r (Kim & Kim 2018)
  int num_sectors = 60;    ///< N_s: sectors of 2 pi / N_s (6 deg) each, sector 0 starting at azimuth -pi (Kim & Kim 2018)
  float max_range = 80.f;  ///< [m] L_max: points at this horizontal range or beyond are left out (Kim & Kim 2018)
  /// [m] added to the sensor-frame z so heights are positive: bin value = max(z) + height_offset, clamped at 0.
  /// 2.0 m is the lidar height the authors' reference implementation adds (SC-LeGO-LOAM, LIDAR_HEIGHT = 2.0); for a
  /// car-mounted sensor 1.7-2 m up (KITTI's HDL-64E: 1.73 m) the ground lands at 0-0.3 m, so a bin that sees only road
  /// is still occupied (> 0) and counts in the ring key, while returns below the road (noise, ramps) clamp to 0.
  float height_offset = 2.0f;
  /// [m] quantisation step of the stored heights: bins hold round(height / step) in 0..255, i.e. 0-25.5 m above
  /// the ground plane at 0.1 m (23.5 m above the sensor); taller values saturate at 255.
  float height_step = 0.1f;
  int min_points = 100;  ///< fewer finite points within max_range: no descriptor (ok = false)

  std::optional<std::string> validate() const;
};

/// @brief One scan's Scan Context. `bins` is sector-major: bins[s * num_rings + r] (a column, i.e. a sector, is
/// contiguous) with r = 0 the innermost ring and s = 0 the sector at azimuth -pi .. -pi + 2 pi / N_s.
/// The derived fields (column_norms, ring_key) are recomputed from `bins` by decode_place_descriptor().
struct PlaceDescriptor {
  bool ok = false;
  std::string error;  ///< why ok == false
  int num_rings = 0;
  int num_sectors = 0;
  float max_range = 0.f;            ///< [m] as computed with
  float height_offset = 0.f;        ///< [m] as computed with
  float height_step = 0.f;          ///< [m] per quantisation step
  std::vector<std::uint8_t> bins;   ///< num_sectors * num_rings quantised heights; 0 = empty bin
  std::vector<float> column_norms;  ///< per sector: L2 norm of its column in quantisation steps (0 = empty column)
  std::vector<float> ring_key;      ///< per ring: share of occupied bins, in [0, 1] (Kim & Kim 2018, ring key)
  int num_points = 0;               ///< points binned (finite, within max_range)
};

/// @brief The shift-minimised distance between two descriptors.
struct PlaceMatch {
  bool ok = false;              ///< false when the descriptors are not ok or differ in shape (distance 1 then)
  float distance = 1.f;         ///< in [0, 1]: 1 - mean column cosine at the best shift (0 = identical)
  int shift = 0;                ///< best sector shift k: query column s is compared with match column (s + k) mod N_s
  double yaw_match_query = 0.;  ///< [rad] in (-pi, pi]: p_match = Rz(yaw_match_query) * p_query (x, y of the sensors)
};

/// @brief The Scan Context of `cloud` (sensor frame, z up). Non-finite points are skipped. Never throws: an invalid
/// config or fewer than config.min_points usable points gives ok == false with the reason.
PlaceDescriptor compute_place_descriptor(const PointCloud& cloud, const ScanContextConfig& config = {});
/// @brief The same seen from `origin` (x, y in the sensor frame; axes as the sensor's): the place as a sensor there would
/// bin it (global retrieval's lateral augmentation).
PlaceDescriptor compute_place_descriptor(const PointCloud& cloud, const ScanContextConfig& config, const Eigen::Vector2f& origin);

/// @brief Kim & Kim 2018, Eq. (5)-(6): d(I_q, I_c) = min over circular sector shifts of the mean over columns of
/// (1 - cos(c_q^j, c_c^j)). Columns empty in both descriptors are left out of the mean; a column empty in only one of
/// them counts as cosine 0 (distance 1); when every column is empty in both, the distance is 1. Cosines of
/// non-negative heights lie in [0, 1], so does the distance. The yaw is refined between sectors by a parabola
/// through the distances at the best shift and its two neighbours (at most half a sector either way).
/// @note Ties between shifts go to the smallest shift index. Cost: one (N_s x N_r) x (N_r x N_s) product.
PlaceMatch place_distance(const PlaceDescriptor& query, const PlaceDescriptor& match);

/// @brief Bytes for the map store: "LPSC", u16 version (1), u16 num_rings, u16 num_sectors, u16 0, f32 max_range,
/// f32 height_offset, f32 height_step, u32 num_points, then the bins (little-endian; 28 + N_r N_s bytes). Empty when the descriptor is not ok.
std::vector<std::uint8_t> encode_place_descriptor(const PlaceDescriptor& descriptor);

/// @brief decode_place_descriptor()'s answer: ok and the descriptor, or the reason ("place descriptor: ...").
struct DecodedPlaceDescriptor {
  bool ok = false;
  std::string error;
  PlaceDescriptor descriptor;
};
/// @brief Decodes encode_place_descriptor() bytes: magic, version, a config that validates and exactly as many bytes as
/// it states are checked. Never throws.
DecodedPlaceDescriptor decode_place_descriptor(const std::uint8_t* data, std::size_t size);
DecodedPlaceDescriptor decode_place_descriptor(const std::vector<std::uint8_t>& bytes);

namespace detail {
/// Column norms and ring key from the bins (compute and decode share it).
void finish_place_descriptor(PlaceDescriptor& d);
/// Columns scaled to unit length (empty ones stay 0), sector-major like bins.
void normalised_columns(const PlaceDescriptor& d, float* out);
/// place_distance() with the query's columns already normalised (the index normalises a query once).
PlaceMatch place_distance_normalised(const PlaceDescriptor& query, const float* query_normalised, const std::uint8_t* match_bins,
                                     const float* match_norms);
}  // namespace detail

}  // namespace loopd
