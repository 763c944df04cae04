#include "scan_decode.hpp"

#include <cmath>
#include <cstring>
#include <exception>
#include <new>
#include <string>
#include <utility>

#include <loopd/point_cloud_t.hpp>

#include "message_convert.hpp"
#include "point_cloud_walk.hpp"
#include "wire_walker.hpp"

namespace loopd {
namespace {

std::uint32_t big_endian_u32(const std::uint8_t* p) {
  std::uint32_t u = 0;
  std::memcpy(&u, p, sizeof u);
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  u = __builtin_bswap32(u);
#endif
  return u;
}

float big_endian_float(const std::uint8_t* p) {
  const std::uint32_t u = big_endian_u32(p);
  float f = 0.0F;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

std::int16_t big_endian_i16(const std::uint8_t* p) { return static_cast<std::int16_t>((static_cast<unsigned>(p[0]) << 8) | p[1]); }

/// Walks either layout of point_cloud_t (the walk bounded_decode proves messages with) and records where the arrays are.
PointCloudLayout walk_scan(WireWalker& w, const DecodeLimits& limits) {
  const std::int64_t hash = w.int64("fingerprint");
  const bool version1 = hash == kPointCloudV1Hash;
  if (w.ok() && !version1 && hash != point_cloud_t::getHash())
    w.fail_at(0, "fingerprint", "does not match the message type (another type, or another version of it)");
  const PointCloudLayout l = walk_point_cloud(w, limits, !version1);
  w.end();
  return l;
}

/// from_message's checks of the contents (the same rules, message_convert.hpp), with where each failed.
DecodeResult check_contents(const std::uint8_t* bytes, const PointCloudLayout& l) {
  DecodeResult r;
  const auto fail = [&r](std::string reason, std::size_t offset) {
    r.reason = std::move(reason);
    r.offset = offset;
    return r;
  };
  std::string reason = ring_indices_error(static_cast<std::int64_t>(l.points), static_cast<std::int64_t>(l.rings));
  if (!reason.empty()) return fail(reason, l.ring_at - 4);
  reason = num_rings_error(l.num_rings);
  if (!reason.empty()) return fail(reason, l.num_rings_at);
  for (std::size_t i = 0; i < l.times; ++i) {
    const float t = big_endian_float(bytes + l.times_at + 4 * i);
    if (!point_time_ok(t)) return fail(point_time_error(t), l.times_at + 4 * i);
  }
  r.ok = true;
  return r;
}

/// Reads the proven, checked arrays into `cloud` (as from_message converts them).
void read_cloud(const std::uint8_t* bytes, const PointCloudLayout& l, PointCloud* cloud) {
  const std::size_t n = l.points;
  const std::uint8_t* x = bytes + l.x_at;
  const std::uint8_t* y = x + 4 * n;
  const std::uint8_t* z = y + 4 * n;
  const std::uint8_t* intensity = z + 4 * n;
  cloud->points.resize(n);
  cloud->intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    cloud->points[i] = Eigen::Vector3f(big_endian_float(x + 4 * i), big_endian_float(y + 4 * i), big_endian_float(z + 4 * i));
    cloud->intensity[i] = big_endian_float(intensity + 4 * i);
  }
  if (l.rings == n && l.num_rings > 0) {
    cloud->ring.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::int16_t ring = big_endian_i16(bytes + l.ring_at + 2 * i);
      cloud->ring[i] = static_cast<std::uint16_t>(ring < 0 ? 0 : ring);
    }
    cloud->num_rings = l.num_rings;
  }
  if (l.times != 0) {
    cloud->time.resize(n);
    for (std::size_t i = 0; i < n; ++i) cloud->time[i] = big_endian_float(bytes + l.times_at + 4 * i);
  }
}

}  // namespace

DecodeResult decode_scan(const void* data, std::size_t size, const DecodeLimits& limits, DecodedScan* out) {
  DecodeResult result;
  if (data == nullptr && size != 0) {
    result.reason = "no data";
    return result;
  }
  WireWalker w(data, size);
  const PointCloudLayout layout = walk_scan(w, limits);
  if (!w.ok()) {
    result.reason = w.error();
    result.offset = w.error_offset();
    return result;
  }
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  result = check_contents(bytes, layout);
  if (!result.ok) return result;
  try {
    DecodedScan scan;
    scan.utime = layout.utime;
    scan.seq = layout.seq;
    read_cloud(bytes, layout, &scan.cloud);
    *out = std::move(scan);
  } catch (const std::bad_alloc&) {
    result.ok = false;
    result.reason = "out of memory while decoding";
  }
  return result;
}

}  // namespace loopd
