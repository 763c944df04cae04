// PointCloud2 field layouts (decode_pointcloud2) on hand-built byte buffers: float32 and float64 xyz, big-endian data,
// organised clouds with NaN cells, integer rings of several types, and hostile layouts that must fail with an error
// naming the field or length at fault (never a read outside the buffer).
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "loopd/io/pointcloud2_layout.hpp"

using namespace loopd;

namespace {

/// Builds a PointCloud2 layout and its data: fields are appended in order (offset = current point size unless
/// given), points are written value by value in the declared types, byte-swapped for big-endian.
class CloudBuilder {
 public:
  explicit CloudBuilder(bool big_endian = false) { layout.is_bigendian = big_endian; }
  CloudBuilder& field(const std::string& name, PointFieldType type, std::uint32_t count = 1) {
    layout.fields.push_back({name, step_, static_cast<std::uint8_t>(type), count});
    step_ += count * size_of(type);
    return *this;
  }
  CloudBuilder& pad(std::uint32_t bytes) {
    step_ += bytes;
    return *this;
  }
  /// One point: one value per field (a field's further values, if count > 1, are written as 0).
  CloudBuilder& point(const std::vector<double>& values) {
    std::vector<std::uint8_t> p(step_, 0xAB);  // padding bytes are garbage on purpose
    for (std::size_t i = 0; i < layout.fields.size(); ++i) {
      const PointFieldLayout& f = layout.fields[i];
      for (std::uint32_t k = 0; k < f.count; ++k)
        put(&p[f.offset + k * size_of(static_cast<PointFieldType>(f.datatype))], f, k == 0 ? values.at(i) : 0.0);
    }
    points_.push_back(p);
    return *this;
  }
  /// Sets width x height (default: all points in one row) and row_step (default: width x point_step, plus extra).
  std::vector<std::uint8_t> build(std::uint32_t height = 1, std::uint32_t row_padding = 0) {
    layout.point_step = step_;
    layout.height = height;
    layout.width = static_cast<std::uint32_t>(points_.size()) / height;
    layout.row_step = layout.width * step_ + row_padding;
    std::vector<std::uint8_t> data;
    for (std::uint32_t r = 0; r < height; ++r) {
      for (std::uint32_t c = 0; c < layout.width; ++c) {
        const auto& p = points_[r * layout.width + c];
        data.insert(data.end(), p.begin(), p.end());
      }
      data.insert(data.end(), row_padding, 0xCD);
    }
    return data;
  }
  PointCloud2Layout layout;

 private:
  static std::uint32_t size_of(PointFieldType t) {
    switch (t) {
      case PointFieldType::kInt8:
      case PointFieldType::kUint8:
        return 1;
      case PointFieldType::kInt16:
      case PointFieldType::kUint16:
        return 2;
      case PointFieldType::kFloat64:
        return 8;
      default:
        return 4;
    }
  }
  template <typename T>
  void store(std::uint8_t* dst, T v) const {
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i) dst[i] = layout.is_bigendian ? b[sizeof(T) - 1 - i] : b[i];
  }
  void put(std::uint8_t* dst, const PointFieldLayout& f, double v) const {
    switch (static_cast<PointFieldType>(f.datatype)) {
      case PointFieldType::kInt8:
        return store(dst, static_cast<std::int8_t>(v));
      case PointFieldType::kUint8:
        return store(dst, static_cast<std::uint8_t>(v));
      case PointFieldType::kInt16:
        return store(dst, static_cast<std::int16_t>(v));
      case PointFieldType::kUint16:
        return store(dst, static_cast<std::uint16_t>(v));
      case PointFieldType::kInt32:
        return store(dst, static_cast<std::int32_t>(v));
      case PointFieldType::kUint32:
        return store(dst, static_cast<std::uint32_t>(v));
      case PointFieldType::kFloat32:
        return store(dst, static_cast<float>(v));
      case PointFieldType::kFloat64:
        return store(dst, v);
    }
  }
  std::uint32_t step_ = 0;
  std::vector<std::vector<std::uint8_t>> points_;
};

const double kNan = std::numeric_limits<double>::quiet_NaN();

PointCloud2Decoded decode(CloudBuilder& b, const std::vector<std::uint8_t>& data, const PointCloud2Options& options = {}) {
  return decode_pointcloud2(b.layout, data.data(), data.size(), options);
}

std::string decode_error(CloudBuilder& b, const std::vector<std::uint8_t>& data) {
  const PointCloud2Decoded d = decode(b, data);
  CHECK_FALSE(d.ok);
  CHECK(d.cloud.empty());
  return d.error;
}

}  // namespace

TEST_CASE("float32 xyz with intensity and a uint16 ring (the velodyne driver's layout)", "[io][pointcloud2]") {
  CloudBuilder b;
  b.field("x", PointFieldType::kFloat32).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32).pad(4);
  b.field("intensity", PointFieldType::kFloat32).field("ring", PointFieldType::kUint16).pad(2).field("time", PointFieldType::kFloat32);
  b.point({1.5, -2.0, 0.25, 7.0, 3, 0.01}).point({3.0, 4.0, -5.5, 8.0, 15, 0.02}).point({-0.125, 100.0, 9.0, 9.0, 0, 0.03});
  const auto data = b.build();
  REQUIRE(b.layout.point_step == 28);
  const PointCloud2Decoded d = decode(b, data);
  INFO(d.error);
  REQUIRE(d.ok);
  REQUIRE(d.cloud.size() == 3);
  CHECK(d.points_in == 3);
  CHECK(d.dropped_nonfinite == 0);
  CHECK(d.cloud.points[0] == Eigen::Vector3f(1.5f, -2.f, 0.25f));
  CHECK(d.cloud.points[2] == Eigen::Vector3f(-0.125f, 100.f, 9.f));
  REQUIRE(d.cloud.has_intensity());
  CHECK(d.cloud.intensity == std::vector<float>{7.f, 8.f, 9.f});
  CHECK(d.cloud.ring == std::vector<std::uint16_t>{3, 15, 0});
  CHECK(d.ring_field == "ring");
  CHECK(d.intensity_field == "intensity");
  CHECK(d.max_ring == 15);
  CHECK(d.time_field == "time");
  CHECK(d.time == std::vector<float>{0.01f, 0.02f, 0.03f});
}

TEST_CASE("float64 xyz are read at full precision and rounded to float once", "[io][pointcloud2]") {
  CloudBuilder b;
  b.field("intensity", PointFieldType::kUint8)
      .field("x", PointFieldType::kFloat64)
      .field("y", PointFieldType::kFloat64)
      .field("z", PointFieldType::kFloat64);
  const double x = 123.456789012345, y = -0.1, z = 1e-3;
  b.point({200, x, y, z}).point({0, 1.0, 2.0, 3.0});
  const auto data = b.build();
  const PointCloud2Decoded d = decode(b, data);
  REQUIRE(d.ok);
  REQUIRE(d.cloud.size() == 2);
  CHECK(d.cloud.points[0] == Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  CHECK(d.cloud.intensity == std::vector<float>{200.f, 0.f});
  CHECK_FALSE(d.cloud.has_rings());
  CHECK(d.ring_field.empty());
}

TEST_CASE("big-endian data is byte-swapped (is_bigendian honoured)", "[io][pointcloud2]") {
  for (bool big : {false, true}) {
    CloudBuilder b(big);
    b.field("x", PointFieldType::kFloat64).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32);
    b.field("intensity", PointFieldType::kUint16).field("laser_id", PointFieldType::kInt32);
    b.point({-7.25, 0.5, 1024.0, 513, 63}).point({1e5, -3.0, 0.0, 65535, 1});
    const auto data = b.build();
    const PointCloud2Decoded d = decode(b, data);
    INFO("big-endian " << big << ": " << d.error);
    REQUIRE(d.ok);
    CHECK(d.cloud.points[0] == Eigen::Vector3f(-7.25f, 0.5f, 1024.f));
    CHECK(d.cloud.points[1] == Eigen::Vector3f(1e5f, -3.f, 0.f));
    CHECK(d.cloud.intensity == std::vector<float>{513.f, 65535.f});
    CHECK(d.cloud.ring == std::vector<std::uint16_t>{63, 1});
    CHECK(d.ring_field == "laser_id");
  }
  // The same bytes read with the wrong flag give other numbers: the flag is what decides.
  CloudBuilder b(true);
  b.field("x", PointFieldType::kFloat32).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32).point({1.0, 2.0, 3.0});
  const auto data = b.build();
  b.layout.is_bigendian = false;
  const PointCloud2Decoded wrong = decode(b, data);
  CHECK((!wrong.ok || wrong.cloud.empty() || wrong.cloud.points[0] != Eigen::Vector3f(1.f, 2.f, 3.f)));
}

TEST_CASE("an organised cloud with NaN cells keeps the finite points in row-major order", "[io][pointcloud2]") {
  CloudBuilder b;
  b.field("x", PointFieldType::kFloat32)
      .field("y", PointFieldType::kFloat32)
      .field("z", PointFieldType::kFloat32)
      .field("ring", PointFieldType::kUint8);
  // 2 rows x 3 columns; row_step with 5 bytes of padding at the end of each row.
  b.point({1, 0, 0, 0}).point({kNan, kNan, kNan, 0}).point({2, 0, 0, 0});
  b.point({3, 1, kNan, 1}).point({4, 1, 0, 1}).point({std::numeric_limits<double>::infinity(), 1, 0, 1});
  const auto data = b.build(2, 5);
  REQUIRE(b.layout.width == 3);
  REQUIRE(b.layout.row_step == 3 * b.layout.point_step + 5);
  const PointCloud2Decoded d = decode(b, data);
  INFO(d.error);
  REQUIRE(d.ok);
  CHECK(d.points_in == 6);
  CHECK(d.dropped_nonfinite == 3);
  REQUIRE(d.cloud.size() == 3);
  CHECK(d.cloud.points[0].x() == 1.f);
  CHECK(d.cloud.points[1].x() == 2.f);
  CHECK(d.cloud.points[2].x() == 4.f);
  CHECK(d.cloud.ring == std::vector<std::uint16_t>{0, 0, 1});
}

TEST_CASE("rings of uint8, uint16 and int32 fields, and ring values out of range", "[io][pointcloud2]") {
  for (PointFieldType t :
       {PointFieldType::kUint8, PointFieldType::kUint16, PointFieldType::kInt32, PointFieldType::kInt16, PointFieldType::kUint32}) {
    CloudBuilder b;
    b.field("x", PointFieldType::kFloat32).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32).field("ring", t);
    b.point({1, 2, 3, 0}).point({1, 2, 3, 127}).point({1, 2, 3, 31});
    const auto data = b.build();
    const PointCloud2Decoded d = decode(b, data);
    INFO(point_field_type_name(static_cast<std::uint8_t>(t)) << ": " << d.error);
    REQUIRE(d.ok);
    CHECK(d.cloud.ring == std::vector<std::uint16_t>{0, 127, 31});
    CHECK(d.max_ring == 127);
  }
  CloudBuilder neg;
  neg.field("x", PointFieldType::kFloat32)
      .field("y", PointFieldType::kFloat32)
      .field("z", PointFieldType::kFloat32)
      .field("ring", PointFieldType::kInt32);
  neg.point({1, 2, 3, 5}).point({1, 2, 3, -1});
  auto data = neg.build();
  CHECK(decode_error(neg, data) == "field 'ring': value -1 at row 0, column 1 is outside 0..511");
  CloudBuilder big;
  big.field("x", PointFieldType::kFloat32)
      .field("y", PointFieldType::kFloat32)
      .field("z", PointFieldType::kFloat32)
      .field("ring", PointFieldType::kUint32);
  big.point({1, 2, 3, 4000000000.0});
  data = big.build();
  CHECK(decode_error(big, data).find("outside 0..511") != std::string::npos);
  CloudBuilder fl;
  fl.field("x", PointFieldType::kFloat32)
      .field("y", PointFieldType::kFloat32)
      .field("z", PointFieldType::kFloat32)
      .field("ring", PointFieldType::kFloat32);
  fl.point({1, 2, 3, 4});
  data = fl.build();
  CHECK(decode_error(fl, data) == "field 'ring' is float32; a ring index must be an integer type");
}

TEST_CASE("hostile layouts fail with an error naming the field or the length", "[io][pointcloud2]") {
  auto xyz = [](CloudBuilder& b) {
    b.field("x", PointFieldType::kFloat32).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32);
    b.point({1, 2, 3}).point({4, 5, 6});
    return b.build();
  };
  SECTION("missing x") {
    CloudBuilder b;
    b.field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32).field("intensity", PointFieldType::kFloat32).point({1, 2, 3});
    const auto data = b.build();
    CHECK(decode_error(b, data) == "field 'x' missing (fields: y, z, intensity)");
  }
  SECTION("no fields at all") {
    PointCloud2Layout l;
    l.width = 1;
    l.point_step = l.row_step = 16;
    const std::vector<std::uint8_t> data(16);
    CHECK(decode_pointcloud2(l, data.data(), data.size()).error == "field 'x' missing (fields: none)");
  }
  SECTION("point_step too small for a field") {
    CloudBuilder b;
    auto data = xyz(b);
    b.layout.point_step = 8;
    b.layout.row_step = 16;
    CHECK(decode_error(b, data) == "field 'z' (offset 8, 1 x float32) ends at byte 12, beyond point_step 8");
  }
  SECTION("data too short") {
    CloudBuilder b;
    auto data = xyz(b);
    data.resize(data.size() - 1);
    CHECK(decode_error(b, data) == "data holds 23 bytes, height x row_step = 1 x 24 needs 24");
    CHECK(decode_pointcloud2(b.layout, nullptr, 0).error == "data holds 0 bytes, height x row_step = 1 x 24 needs 24");
  }
  SECTION("row_step smaller than a row") {
    CloudBuilder b;
    auto data = xyz(b);
    b.layout.row_step = 23;
    CHECK(decode_error(b, data) == "row_step 23 is less than width x point_step = 2 x 12");
  }
  SECTION("width and height that overflow 32 bits, and too many points") {
    CloudBuilder b;
    auto data = xyz(b);
    b.layout.width = 0xFFFFFFFFu;
    b.layout.height = 0xFFFFFFFFu;
    CHECK(decode_error(b, data).find("more than the limit 4000000") != std::string::npos);
    b.layout.width = 0x10000000u;
    b.layout.height = 1;
    b.layout.row_step = 0xFFFFFFFFu;
    CHECK(decode_error(b, data).find("more than the limit") != std::string::npos);
    b.layout.width = 1000;
    b.layout.height = 1000;  // 1e6 points within the limit, but 12 MB the 24 bytes do not hold
    CHECK(decode_error(b, data).find("row_step") != std::string::npos);
    b.layout.row_step = 12000;
    CHECK(decode_error(b, data) == "data holds 24 bytes, height x row_step = 1000 x 12000 needs 12000000");
  }
  SECTION("offset and count that overflow 32 bits") {
    CloudBuilder b;
    auto data = xyz(b);
    b.layout.fields[1].offset = 0xFFFFFFFEu;
    CHECK(decode_error(b, data).find("field 'y' (offset 4294967294") != std::string::npos);
    b.layout.fields[1].offset = 4;
    b.layout.fields[1].count = 0x40000000u;
    CHECK(decode_error(b, data).find("beyond point_step 12") != std::string::npos);
    b.layout.fields[1].count = 0;
    CHECK(decode_error(b, data) == "field 'y' has count 0");
  }
  SECTION("unknown or integer datatype of x") {
    CloudBuilder b;
    auto data = xyz(b);
    b.layout.fields[0].datatype = 9;
    CHECK(decode_error(b, data) == "field 'x' has unknown datatype 9");
    b.layout.fields[0].datatype = static_cast<std::uint8_t>(PointFieldType::kInt32);
    CHECK(decode_error(b, data) == "field 'x' is int32; x, y and z must be float32 or float64");
  }
  SECTION("an unknown datatype on a field that is not read is ignored") {
    CloudBuilder b;
    b.field("x", PointFieldType::kFloat32)
        .field("y", PointFieldType::kFloat32)
        .field("z", PointFieldType::kFloat32)
        .field("rgb", PointFieldType::kFloat32);
    b.point({1, 2, 3, 0});
    const auto data = b.build();
    b.layout.fields[3].datatype = 0;
    b.layout.fields[3].offset = 0xFFFFFF00u;
    CHECK(decode(b, data).ok);
  }
}

TEST_CASE("an empty cloud decodes to no points, the first of two equal field names counts", "[io][pointcloud2]") {
  CloudBuilder b;
  b.field("x", PointFieldType::kFloat32)
      .field("y", PointFieldType::kFloat32)
      .field("z", PointFieldType::kFloat32)
      .field("x", PointFieldType::kFloat32);
  auto data = b.build();
  PointCloud2Decoded d = decode_pointcloud2(b.layout, nullptr, 0);
  CHECK(d.ok);
  CHECK(d.cloud.empty());
  CHECK(d.points_in == 0);
  b.point({1, 2, 3, 99});
  data = b.build();
  d = decode(b, data);
  REQUIRE(d.ok);
  CHECK(d.cloud.points[0] == Eigen::Vector3f(1.f, 2.f, 3.f));
  // Width 0 with 2^32 - 1 rows of row_step 0 holds no point: decoded at once (the fuzzer found it looping over rows).
  b.layout.width = 0;
  b.layout.height = 0xFFFFFFFFu;
  b.layout.row_step = 0;
  d = decode_pointcloud2(b.layout, nullptr, 0);
  CHECK(d.ok);
  CHECK(d.cloud.empty());
}

TEST_CASE("per-point times of the velodyne, Ouster, Livox and Hesai layouts become seconds relative to the stamp", "[io][pointcloud2]") {
  auto cloud = [](const char* name, PointFieldType type, const std::vector<double>& times, bool big_endian = false) {
    CloudBuilder b(big_endian);
    b.field("x", PointFieldType::kFloat32).field("y", PointFieldType::kFloat32).field("z", PointFieldType::kFloat32).field(name, type);
    for (std::size_t i = 0; i < times.size(); ++i) b.point({i == 1 ? kNan : 1.0, 2, 3, times[i]});  // point 1 is dropped
    return b;
  };
  PointCloud2Options options;
  options.stamp = 1700000000.25;
  SECTION("time: float32 seconds") {
    CloudBuilder b = cloud("time", PointFieldType::kFloat32, {-0.1, -0.05, 0.0});
    const PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    CHECK(d.time_field == "time");
    CHECK(d.time == std::vector<float>{-0.1f, 0.0f});
  }
  SECTION("t: uint32 nanoseconds (Ouster), big-endian") {
    CloudBuilder b = cloud("t", PointFieldType::kUint32, {0, 50000000, 99000000}, true);
    const PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    REQUIRE(d.time.size() == 2);
    CHECK(d.time[0] == 0.0f);
    CHECK(d.time[1] == Approx(0.099).margin(1e-9));
  }
  SECTION("offset_time: uint32 nanoseconds (Livox)") {
    CloudBuilder b = cloud("offset_time", PointFieldType::kUint32, {1000, 2000, 3000000});
    const PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    CHECK(d.time_field == "offset_time");
    REQUIRE(d.time.size() == 2);
    CHECK(d.time[1] == Approx(0.003).margin(1e-9));
  }
  SECTION("timestamp: float64 seconds since the epoch (Hesai)") {
    CloudBuilder b = cloud("timestamp", PointFieldType::kFloat64, {options.stamp - 0.1, 0.0, options.stamp + 0.0375});
    const PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    REQUIRE(d.time.size() == 2);
    CHECK(d.time[0] == Approx(-0.1).margin(1e-6));  // a double at 1.7e9 s resolves 0.24 us
    CHECK(d.time[1] == Approx(0.0375).margin(1e-6));
  }
  SECTION("times more than max_time_offset from the stamp are not used, the points are kept") {
    CloudBuilder b = cloud("timestamp", PointFieldType::kFloat64, {0.05, 0.0, 0.06});  // relative values in an absolute field
    const PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    CHECK(d.cloud.size() == 2);
    CHECK(d.time.empty());
    CHECK(d.time_error == "field 'timestamp': the time of point 0 is not finite or more than 1.000000 s from the stamp");
  }
  SECTION("a NaN time, an integer 'time' field, a time field beyond point_step") {
    CloudBuilder b = cloud("time", PointFieldType::kFloat64, {0.0, 0.0, kNan});
    PointCloud2Decoded d = decode(b, b.build(), options);
    REQUIRE(d.ok);
    CHECK(d.time.empty());
    CHECK(d.time_error.find("the time of point 1 is not finite") != std::string::npos);
    CloudBuilder i = cloud("time", PointFieldType::kInt32, {1, 2, 3});
    d = decode(i, i.build(), options);
    REQUIRE(d.ok);
    CHECK(d.time.empty());
    CHECK(d.time_error == "field 'time' is int32, not seconds as a float");
    CloudBuilder far = cloud("t", PointFieldType::kUint32, {1, 2, 3});
    const auto data = far.build();
    far.layout.fields[3].offset = 100;
    CHECK(decode_error(far, data) == "field 't' (offset 100, 1 x uint32) ends at byte 104, beyond point_step 16");
  }
}
