#pragma once
/// @file How a fleet numbers its sessions: vehicle V opens sessions V * kSessionsPerVehicle + k, so a session id names
/// its vehicle in every record (keyframe keys, loops, corrections) without a vehicle column of its own.
#include <cstdint>

#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief Sessions a fleet vehicle may open (SessionId is 32-bit: vehicles 0 .. kMaxVehicle).
inline constexpr SessionId kSessionsPerVehicle = 1000000;
inline constexpr int kMaxVehicle = 2146;

/// @brief The vehicle whose sessions `session` belongs to.
inline int vehicle_of(SessionId session) { return static_cast<int>(session / kSessionsPerVehicle); }

/// @brief The first session vehicle `vehicle` opens (0 for vehicle 0 and for no vehicle, -1).
inline SessionId first_session_of(int vehicle) { return vehicle > 0 ? vehicle * kSessionsPerVehicle : 0; }

/// @brief The sessions of `vehicle`, first and last; every session id for -1 (no vehicle: the whole map).
struct SessionRange {
  std::int64_t first = 0, last = 0;
};
inline SessionRange sessions_of(int vehicle) {
  if (vehicle < 0) return {std::int64_t{INT32_MIN}, std::int64_t{INT32_MAX}};
  const std::int64_t first = std::int64_t{vehicle} * kSessionsPerVehicle;
  return {first, first + kSessionsPerVehicle - 1};
}

}  // namespace loopd
