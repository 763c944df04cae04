// Scan Context (Kim & Kim 2018): rotation invariance with the yaw recovered, small translations, the byte codec, the
// config checks.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "descriptor/scan_context_scene.hpp"
#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/fast_atan2.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/descriptor/scan_context.hpp"

using namespace loopd;

namespace {
constexpr double kDeg = M_PI / 180.0;
double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }
}  // namespace

TEST_CASE("Scan Context: a scene turned by a known yaw is at distance ~0 and the yaw is recovered within a sector") {
  const PointCloud match = test::scan_context_scene(1);
  const PlaceDescriptor dm = compute_place_descriptor(match);
  REQUIRE(dm.ok);
  for (double yaw_deg : {0.0, 3.0, 17.0, 90.0, 150.0, 179.0, -33.0, -120.0, -150.0}) {
    // query points p_q = Rz(a) p_m, so p_m = Rz(-a) p_q: yaw_match_query = -a
    const PointCloud query = transform(match, make_isometry(0, 0, 0, yaw_deg * kDeg));
    const PlaceDescriptor dq = compute_place_descriptor(query);
    REQUIRE(dq.ok);
    const PlaceMatch m = place_distance(dq, dm);
    INFO("yaw " << yaw_deg << " deg: distance " << m.distance << ", yaw_match_query " << m.yaw_match_query / kDeg << " deg");
    REQUIRE(m.ok);
    CHECK(m.distance < 0.12f);
    CHECK(std::abs(wrap(m.yaw_match_query + yaw_deg * kDeg)) < 6.0 * kDeg);
    // and the other way round: the yaw flips sign
    const PlaceMatch back = place_distance(dm, dq);
    CHECK(std::abs(wrap(back.yaw_match_query - yaw_deg * kDeg)) < 6.0 * kDeg);
  }
}

TEST_CASE("Scan Context: identical scans are at distance 0, 1-2 m moved stays well below another place") {
  const PointCloud scene = test::scan_context_scene(1);
  const PlaceDescriptor d = compute_place_descriptor(scene);
  REQUIRE(d.ok);
  const PlaceMatch self = place_distance(d, d);
  CHECK(self.distance == Approx(0.f).margin(1e-5));
  CHECK(self.shift == 0);
  float other_min = 1.f;
  for (std::uint32_t seed : {2u, 3u, 4u, 5u}) {
    const PlaceDescriptor o = compute_place_descriptor(test::scan_context_scene(seed));
    REQUIRE(o.ok);
    other_min = std::min(other_min, place_distance(d, o).distance);
  }
  for (double dx : {1.0, 2.0}) {
    const PointCloud moved = transform(scene, make_isometry(dx, 0.5 * dx, 0, 20 * kDeg));
    const PlaceMatch m = place_distance(compute_place_descriptor(moved), d);
    INFO("moved " << dx << " m: " << m.distance << ", nearest other place " << other_min);
    CHECK(m.distance < 0.6f * other_min);
  }
}

TEST_CASE("Scan Context: bins hold the highest point + offset, quantised, empty bins 0, ring key = occupancy") {
  ScanContextConfig config;
  config.min_points = 2;
  PointCloud c;
  c.points = {{10.f, 0.1f, -1.0f}, {10.2f, 0.15f, 0.5f}, {-3.f, -0.2f, -2.5f}, {200.f, 0.f, 0.f}};
  c.points.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f);
  const PlaceDescriptor d = compute_place_descriptor(c, config);
  REQUIRE(d.ok);
  CHECK(d.num_points == 3);  // the far and the NaN point are left out
  // (10, 0.1): ring 2 (4 m rings), azimuth ~0 -> sector 30; height 0.5 + 2.0 = 2.5 m -> 25 steps
  CHECK(int(d.bins[30 * 20 + 2]) == 25);
  // (-3, -0.2): ring 0, azimuth ~ -pi -> sector 0; -2.5 + 2.0 < 0 clamps to 0
  CHECK(int(d.bins[0]) == 0);
  CHECK(d.ring_key[2] == Approx(1.0 / 60));
  CHECK(d.ring_key[0] == 0.f);
  CHECK(d.column_norms[30] == Approx(25.f));
  config.min_points = 4;
  const PlaceDescriptor few = compute_place_descriptor(c, config);
  CHECK_FALSE(few.ok);
  CHECK(few.error.find("fewer than 4") != std::string::npos);
  CHECK_FALSE(compute_place_descriptor(PointCloud{}).ok);
  CHECK_FALSE(place_distance(few, d).ok);
}

TEST_CASE("Scan Context: each point lands in the sector std::atan2 gives it, on and beside every sector boundary") {
  // The sector is taken from a fast atan2 away from the boundaries and from std::atan2 near them; the bins must be
  // exactly those of std::atan2. Points on, and a few float steps either side of, each of the 60 boundaries (and the
  // axes, -0 included), one point per descriptor, each with its own height so the bin it lands in is unambiguous.
  ScanContextConfig config;
  config.min_points = 1;
  const float sectors_per_rad = static_cast<float>(config.num_sectors / (2.0 * M_PI));
  std::vector<Eigen::Vector2f> xy = {{1.f, 0.f}, {-1.f, 0.f}, {-1.f, -0.f}, {0.f, 1.f}, {0.f, -1.f}, {-0.f, -1.f}};
  for (int b = 0; b <= config.num_sectors; ++b) {
    const double boundary = -M_PI + b * 2.0 * M_PI / config.num_sectors;
    for (const double eps : {-1e-4, -1e-5, -1e-6, -1e-7, 0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3}) {
      for (const float r : {3.f, 37.f, 79.f}) xy.emplace_back(r * std::cos(boundary + eps), r * std::sin(boundary + eps));
    }
  }
  for (int i = 0; i < 2000; ++i) xy.emplace_back(30.f * std::cos(i * 0.7311), 30.f * std::sin(i * 0.7311));
  int checked = 0;
  for (const Eigen::Vector2f& p : xy) {
    PointCloud c;
    c.points = {{p.x(), p.y(), 1.0f}};  // height 1 + 2 = 3 m -> 30 steps
    const PlaceDescriptor d = compute_place_descriptor(c, config);
    REQUIRE(d.ok);
    const float azimuth = std::atan2(p.y(), p.x()) + static_cast<float>(M_PI);
    const auto sector = std::min<std::size_t>(config.num_sectors - 1, static_cast<std::size_t>(azimuth * sectors_per_rad));
    const auto ring = std::min<std::size_t>(
        config.num_rings - 1, static_cast<std::size_t>(std::sqrt(p.x() * p.x() + p.y() * p.y()) * (config.num_rings / config.max_range)));
    INFO("x " << p.x() << " y " << p.y() << " expected sector " << sector);
    CHECK(int(d.bins[sector * config.num_rings + ring]) == 30);
    ++checked;
  }
  CHECK(checked == static_cast<int>(xy.size()));
  // The premise: fast_atan2's error stays within the 5e-4 rad band that scan_context.cpp hands to std::atan2.
  double worst = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double a = -M_PI + 2.0 * M_PI * (i + 0.5) / 200000.0;
    const float x = static_cast<float>(std::cos(a)), y = static_cast<float>(std::sin(a));
    worst = std::max(worst, std::abs(static_cast<double>(fast_atan2(y, x)) - std::atan2(static_cast<double>(y), static_cast<double>(x))));
  }
  CHECK(worst <= 2.1e-4);
}

TEST_CASE("Scan Context bytes: round trip exact, truncated, wrong version, wrong size rejected with a reason") {
  const PlaceDescriptor d = compute_place_descriptor(test::scan_context_scene(7));
  REQUIRE(d.ok);
  const std::vector<std::uint8_t> bytes = encode_place_descriptor(d);
  REQUIRE(bytes.size() == 28 + 1200);
  const DecodedPlaceDescriptor back = decode_place_descriptor(bytes);
  REQUIRE(back.ok);
  CHECK(back.error.empty());
  CHECK(back.descriptor.bins == d.bins);
  CHECK(back.descriptor.column_norms == d.column_norms);
  CHECK(back.descriptor.ring_key == d.ring_key);
  CHECK(back.descriptor.num_points == d.num_points);
  CHECK(back.descriptor.max_range == d.max_range);
  CHECK(back.descriptor.height_offset == d.height_offset);
  CHECK(back.descriptor.height_step == d.height_step);
  CHECK(encode_place_descriptor(back.descriptor) == bytes);

  auto rejected = [](const std::vector<std::uint8_t>& b, const char* why) {
    const DecodedPlaceDescriptor r = decode_place_descriptor(b);
    INFO(r.error);
    CHECK_FALSE(r.ok);
    CHECK(r.error.find(why) != std::string::npos);
  };
  rejected({}, "shorter than");
  rejected(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 20), "shorter than");
  rejected(std::vector<std::uint8_t>(bytes.begin(), bytes.end() - 1), "need 1228");
  std::vector<std::uint8_t> longer = bytes;
  longer.push_back(0);
  rejected(longer, "need 1228");
  std::vector<std::uint8_t> version = bytes;
  version[4] = 2;
  rejected(version, "version 2");
  std::vector<std::uint8_t> magic = bytes;
  magic[0] = 'X';
  rejected(magic, "magic");
  std::vector<std::uint8_t> rings = bytes;
  rings[6] = 0;
  rings[7] = 0;
  rejected(rings, "num_rings");
  CHECK(encode_place_descriptor(PlaceDescriptor{}).empty());
  CHECK_FALSE(decode_place_descriptor(nullptr, 0).ok);
}

TEST_CASE("ScanContextConfig::validate rejects unusable settings") {
  CHECK_FALSE(ScanContextConfig{}.validate());
  auto bad = [](auto edit) {
    ScanContextConfig c;
    edit(c);
    return c.validate().has_value();
  };
  CHECK(bad([](ScanContextConfig& c) { c.num_rings = 0; }));
  CHECK(bad([](ScanContextConfig& c) { c.num_sectors = 0; }));
  CHECK(bad([](ScanContextConfig& c) { c.num_sectors = 5000; }));
  CHECK(bad([](ScanContextConfig& c) { c.max_range = 0.f; }));
  CHECK(bad([](ScanContextConfig& c) { c.max_range = std::numeric_limits<float>::quiet_NaN(); }));
  CHECK(bad([](ScanContextConfig& c) { c.height_step = 0.f; }));
  CHECK(bad([](ScanContextConfig& c) { c.height_offset = std::numeric_limits<float>::infinity(); }));
  CHECK(bad([](ScanContextConfig& c) { c.min_points = 0; }));
  ScanContextConfig zero;
  zero.num_rings = 0;
  const PlaceDescriptor d = compute_place_descriptor(test::scan_context_scene(1), zero);
  CHECK_FALSE(d.ok);
  CHECK(d.error.find("num_rings") != std::string::npos);
}
