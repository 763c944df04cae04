#pragma once
/// @file The stored form of a keyframe's features: a versioned, zstd-compressed blob for the prepared scan and counts,
/// and the M2DP descriptor as raw little-endian float32 (its own column, read without decompressing any scan).
/// Every back end of the map store uses it. Decoding never throws and never allocates more than the bytes allow.
///
/// Measured on the first 50 keyframes of the simulated HDL-64E town drive (5,913 voxel points and 48 clusters a
/// keyframe, 112 KB in memory): 80.4 KB a blob at zstd level 3, encode 0.83 ms, decode 0.31 ms (level 1: 80.7 KB,
/// 0.56 / 0.63 ms; level 9: 77.3 KB, 3.2 / 0.37 ms). The voxel centroids' low mantissa bytes are noise, so a lossless
/// blob cannot shrink much further.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "loopd/records/keyframe_record.hpp"

namespace loopd {

/// @brief Format version of encode_features(); bump it on any change of the layout (decode refuses other versions).
inline constexpr std::uint32_t kKeyframeCodecVersion = 1;

/// @brief Caps decode_features() checks before allocating (far above what prepare_scan makes: 6000 points, 48
/// clusters of <= 48 points and <= 24 hull vertices).
struct KeyframeCodecLimits {
  std::size_t max_points = 1u << 22;          ///< points (and normals) of the prepared scan
  std::size_t max_clusters = 1u << 16;        ///< segmentation clusters
  std::size_t max_cluster_points = 1u << 20;  ///< points, or hull vertices, of one cluster
  std::size_t max_string = 1u << 16;          ///< bytes of an error string
  std::size_t max_payload = 256u << 20;       ///< bytes of the decompressed payload
  std::size_t max_descriptor = 1u << 16;      ///< descriptor floats
};

/// @brief The features blob: magic "LKFC", version, payload size, then the zstd-compressed payload (the prepared scan:
/// points, packed normals, clusters with every field, counts, timings and error strings; the KeyframeFeatures' ok,
/// error, timings and counts). The descriptor is not in it (encode_descriptor).
std::vector<std::uint8_t> encode_features(const KeyframeFeatures& features, int zstd_level = 3);

/// @brief What decode_features() read, or why it could not.
struct DecodedFeatures {
  bool ok = false;
  std::string error;          ///< what is wrong and at which byte offset (ok = false)
  KeyframeFeatures features;  ///< descriptor left empty (decode_descriptor)
};

/// @brief Decodes an encode_features() blob; refuses (with a reason) a wrong magic or version, a size that does not fit
/// the bytes, a failed decompression, a count over `limits` or trailing bytes. Never throws.
DecodedFeatures decode_features(const std::uint8_t* data, std::size_t size, const KeyframeCodecLimits& limits = {});
inline DecodedFeatures decode_features(const std::vector<std::uint8_t>& bytes, const KeyframeCodecLimits& limits = {}) {
  return decode_features(bytes.data(), bytes.size(), limits);
}

/// @brief The descriptor as raw little-endian float32 (4 bytes a value, no header; bit-identical round trip).
std::vector<std::uint8_t> encode_descriptor(const Eigen::VectorXf& descriptor);

/// @brief What decode_descriptor() read, or why it could not.
struct DecodedDescriptor {
  bool ok = false;
  std::string error;
  Eigen::VectorXf descriptor;
};

/// @brief Decodes encode_descriptor() bytes: refused when the size is not a multiple of 4 or over limits.max_descriptor.
DecodedDescriptor decode_descriptor(const std::uint8_t* data, std::size_t size, const KeyframeCodecLimits& limits = {});

}  // namespace loopd
