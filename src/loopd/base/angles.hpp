#pragma once
/// @file Angle constants shared by every stage (one definition instead of one per file, so that files can also be
///       compiled together in a unity build).

namespace loopd {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kRadPerDeg = kPi / 180.0;

}  // namespace loopd
