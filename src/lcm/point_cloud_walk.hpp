#pragma once
// Internal to src/lcm: the one walk over point_cloud_t's wire layout, shared by bounded_decode (which proves a
// message before LCM's decoder sees it) and scan_decode (which then reads the arrays straight into a PointCloud).
#include <cstddef>
#include <cstdint>

#include "bounded_decode.hpp"
#include "wire_walker.hpp"

namespace loopd {

/// @brief point_cloud_t's scalar fields and where its arrays start in the buffer (offsets from the buffer's start).
struct PointCloudLayout {
  std::int64_t utime = 0, seq = 0;
  std::size_t points = 0, rings = 0, times = 0;
  std::int16_t num_rings = 0;
  std::size_t x_at = 0, ring_at = 0, num_rings_at = 0, times_at = 0;  ///< x, y, z, intensity follow each other
};

/// @brief Walks point_cloud_t from `utime` on (the fingerprint already read), field by field as in
/// lcmtypes/point_cloud_t.lcm: version 1 ends at `num_rings`; `with_times` (today's layout) adds `num_point_times`
/// (0 or num_points) and `time_offset`. Every length is checked against `limits` and the bytes left.
inline PointCloudLayout walk_point_cloud(WireWalker& w, const DecodeLimits& limits, bool with_times) {
  PointCloudLayout l;
  l.utime = w.int64("utime");
  l.seq = w.int64("seq");
  w.string("frame", limits.max_string);
  l.points = static_cast<std::size_t>(w.length("num_points", w.int32("num_points"), limits.max_points, sizeof(float), 4));
  l.x_at = w.position();
  for (const char* field : {"x", "y", "z", "intensity"}) w.skip(field, sizeof(float), l.points);
  l.rings = static_cast<std::size_t>(w.length("num_ring_indices", w.int32("num_ring_indices"), limits.max_points, sizeof(std::int16_t)));
  l.ring_at = w.position();
  w.skip("ring", sizeof(std::int16_t), l.rings);
  l.num_rings_at = w.position();
  l.num_rings = w.int16("num_rings");
  if (with_times) {
    l.times = static_cast<std::size_t>(
        w.optional_length("num_point_times", w.int32("num_point_times"), static_cast<std::int64_t>(l.points), sizeof(float)));
    l.times_at = w.position();
    w.skip("time_offset", sizeof(float), l.times);
  }
  return l;
}

}  // namespace loopd
