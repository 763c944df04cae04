#pragma once
/// @file The stored form of a keyframe's map cloud: coordinates quantised to a fixed step, points sorted and
/// delta-coded as zig-zag varints in separate x / y / z / intensity streams, then zstd (a lossy-by-quantum, otherwise
/// exact codec). Decoding never throws and never allocates more than the header, checked against the bytes, allows.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Format version of encode_map_cloud(); decode refuses others.
inline constexpr std::uint32_t kMapCloudCodecVersion = 1;

/// @brief Caps decode_map_cloud() checks before allocating.
struct MapCloudCodecLimits {
  std::size_t max_points = 1u << 22;
  std::size_t max_payload = 128u << 20;  ///< decompressed bytes
};

/// @brief Encodes `cloud` (sensor frame) with coordinates rounded to `quantum` [m] (|x| / quantum must fit in
/// 2^30: any lidar range) and intensity, when present, to 1 / 65535 of its maximum. Non-finite points must have been
/// removed (they are skipped). Blob: magic "LMPC", u32 version, f32 quantum, f32 intensity scale, u8 has intensity,
/// u32 points, u64 payload bytes, then the zstd frame.
std::vector<std::uint8_t> encode_map_cloud(const PointCloud& cloud, double quantum, int zstd_level = 3);

/// @brief The point count an encode_map_cloud() blob's header names (0 when it is no such blob); nothing decoded.
std::size_t map_cloud_blob_points(const std::uint8_t* data, std::size_t size);

/// @brief What decode_map_cloud() read, or why it could not.
struct DecodedMapCloud {
  bool ok = false;
  std::string error;  ///< what is wrong and where (ok = false)
  PointCloud cloud;   ///< points in the order encode sorted them (x, then y, then z of the quantised coordinates)
  double quantum = 0.0;
};

DecodedMapCloud decode_map_cloud(const std::uint8_t* data, std::size_t size, const MapCloudCodecLimits& limits = {});
inline DecodedMapCloud decode_map_cloud(const std::vector<std::uint8_t>& bytes, const MapCloudCodecLimits& limits = {}) {
  return decode_map_cloud(bytes.data(), bytes.size(), limits);
}

}  // namespace loopd
