#pragma once
/// @file How a joint correction's arrays are stored: four blobs in record_blobs.hpp's encodings (keys, poses, scan
/// times, sessions), so a correction of 100k keyframes is four values, not 100k rows.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/records/store_records.hpp"

namespace loopd::postgres {

struct FleetCorrectionBlobs {
  std::vector<std::uint8_t> keys;      ///< KeyframeKey each (record_blobs kKeyBytes)
  std::vector<std::uint8_t> poses;     ///< T_map_sensor each (kPoseBytes)
  std::vector<std::uint8_t> utimes;    ///< int64 each
  std::vector<std::uint8_t> sessions;  ///< id int32, anchored u8, T_map_session, keyframes int64 each
};

/// @brief The record's arrays as blobs; nullopt when keys, poses and scan times differ in number.
std::optional<FleetCorrectionBlobs> encode_fleet_correction(const FleetCorrectionRecord& record);
/// @brief Fills the record's arrays from the blobs; the error when their sizes do not fit together.
std::optional<std::string> decode_fleet_correction(const FleetCorrectionBlobs& blobs, FleetCorrectionRecord& record);

}  // namespace loopd::postgres
