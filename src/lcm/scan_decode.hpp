#pragma once
#include <cstddef>
#include <cstdint>

#include <loopd/base/point_cloud.hpp>

#include "bounded_decode.hpp"

namespace loopd {

/// @brief A scan read from a point_cloud_t's wire bytes: its stamp, the driver's sequence number and the cloud.
struct DecodedScan {
  std::int64_t utime = 0;
  std::int64_t seq = 0;
  PointCloud cloud;
};

/// @brief Reads a point_cloud_t of either layout (kPointCloudV1Hash or today's) from untrusted bytes straight into a
///        PointCloud: the layout is proven as decode_any_point_cloud proves it, the contents are checked as
///        from_message checks them (ring count 0 or num_points, num_rings within 0..kMaxRings, per-point times finite
///        and within kMaxPointTimeOffset), and only then are the arrays read, once, from the wire into the cloud.
///        No point_cloud_t is built in between: the daemon's scan path decodes every 2 MB HDL-64E scan with one
///        allocation per array and one pass over the bytes. On failure `out` is left as it was. Never throws.
DecodeResult decode_scan(const void* data, std::size_t size, const DecodeLimits& limits, DecodedScan* out);

}  // namespace loopd
