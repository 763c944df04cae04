#pragma once
/// @file A scan's fingerprint: which keyframes a replay's map already holds (resume) is decided by time, pose and this.
#include <cstdint>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief A 64-bit FNV-1a hash of a scan's point count and the exact coordinates of up to 4096 of its points (evenly
///        strided, first and last included). The same scan read from the same log always gives the same value; two
///        drives' scans at the same time differ. Never 0 (0 means "not known" in a map).
std::uint64_t scan_fingerprint(const PointCloud& scan);

}  // namespace loopd
