// PointCloud2 layouts (decode_pointcloud2): the input is a layout followed by the data bytes, so the fuzzer varies
// both. Layout: height u32, width u32, point_step u32, row_step u32, is_bigendian u8, field count u8 (at most 16),
// then per field: name u8 (index into kNames), offset u32, datatype u8, count u32 (little-endian; missing bytes are 0).
// Checks: ok exactly when there is no error; a failure hands out no points; a success holds only finite points, one
// per cell that is not dropped, never more than the data bytes can carry, rings and per-point times inside the limits.
#include <algorithm>
#include <cmath>

#include "fuzz_support.hpp"
#include "loopd/io/pointcloud2_layout.hpp"

namespace {

const char* const kNames[] = {"x", "y", "z", "intensity", "ring", "laser_id", "time", "rgb"};

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(u8()) << (8 * i);
    return v;
  }
  std::uint8_t u8() { return pos_ < size_ ? data_[pos_++] : 0; }
  const std::uint8_t* rest() const { return data_ + std::min(pos_, size_); }
  std::size_t rest_size() const { return size_ - std::min(pos_, size_); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  Bytes in(data, size);
  PointCloud2Layout layout;
  layout.height = in.u32();
  layout.width = in.u32();
  layout.point_step = in.u32();
  layout.row_step = in.u32();
  layout.is_bigendian = (in.u8() & 1) != 0;
  const int fields = std::min<int>(in.u8(), 16);
  for (int i = 0; i < fields; ++i) {
    PointFieldLayout f;
    f.name = kNames[in.u8() % (sizeof(kNames) / sizeof(kNames[0]))];
    f.offset = in.u32();
    f.datatype = in.u8();
    f.count = in.u32();
    layout.fields.push_back(f);
  }
  PointCloud2Options limits;
  limits.max_points = 1u << 20;
  limits.stamp = 1700000000.0;
  const std::size_t bytes = in.rest_size();
  const PointCloud2Decoded d = decode_pointcloud2(layout, in.rest(), bytes, limits);
  fuzz::check(d.ok == d.error.empty(), "ok exactly when there is no error");
  if (!d.ok) {
    fuzz::check(d.cloud.empty() && d.cloud.ring.empty() && d.cloud.intensity.empty(), "a failed decode hands out no points");
    return 0;
  }
  const PointCloud& c = d.cloud;
  fuzz::check(c.size() + d.dropped_nonfinite == d.points_in, "every cell is a point or a dropped non-finite one");
  fuzz::check(d.points_in == 0 || (layout.point_step >= 4 && d.points_in <= bytes / layout.point_step), "no more points than the bytes carry");
  fuzz::check(c.intensity.empty() || c.intensity.size() == c.size(), "intensity is empty or one per point");
  fuzz::check(c.ring.empty() || c.ring.size() == c.size(), "rings are empty or one per point");
  for (const Eigen::Vector3f& p : c.points) fuzz::check(p.allFinite(), "only finite points");
  for (std::uint16_t r : c.ring) fuzz::check(r <= limits.max_ring, "rings inside the limit");
  fuzz::check(d.time.empty() || d.time.size() == c.size(), "times are empty or one per point");
  for (float t : d.time) fuzz::check(std::abs(t) <= limits.max_time_offset, "times finite and within max_time_offset");
  return 0;
}
