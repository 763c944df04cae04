// The map cloud codec: a real simulated scan reduced to its map cloud round-trips within the quantum, and hostile
// bytes are refused with a reason.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include "loopd/store/map_cloud.hpp"
#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/sim/drive.hpp"

using namespace loopd;

namespace {

PointCloud town_map_cloud() {
  DriveConfig dc;
  dc.sensor = "hdl64";
  dc.num_scans = 3;
  dc.seed = 7;
  const Drive drive = make_drive(dc);
  return reduce_to_map_cloud(drive.simulate(2, 2), MapCloudConfig{});
}

/// Points keyed by their quantised coordinates (the decoder returns them sorted).
using CellMap = std::multimap<std::tuple<long, long, long>, std::pair<Eigen::Vector3f, float>>;
std::tuple<long, long, long> cell_of(const Eigen::Vector3f& p, double quantum) {
  return {std::lround(p.x() / quantum), std::lround(p.y() / quantum), std::lround(p.z() / quantum)};
}
CellMap by_cell(const PointCloud& c, double quantum) {
  CellMap out;
  for (std::size_t i = 0; i < c.size(); ++i)
    out.emplace(cell_of(c.points[i], quantum), std::make_pair(c.points[i], c.has_intensity() ? c.intensity[i] : 0.f));
  return out;
}

}  // namespace

TEST_CASE("map cloud: a simulated HDL-64E scan round-trips within half a quantum per axis, intensity within 1/65535") {
  const PointCloud cloud = town_map_cloud();
  REQUIRE(cloud.size() > 10000);
  REQUIRE(cloud.has_intensity());
  const MapCloudConfig config;
  const std::vector<std::uint8_t> blob = encode_map_cloud(cloud, config.quantum);
  CHECK(map_cloud_blob_points(blob.data(), blob.size()) == cloud.size());
  const DecodedMapCloud d = decode_map_cloud(blob);
  REQUIRE(d.ok);
  REQUIRE(d.cloud.size() == cloud.size());
  REQUIRE(d.cloud.has_intensity());
  float max_i = 0.f;
  for (float v : cloud.intensity) max_i = std::max(max_i, v);
  // Each point's decoded twin lies in its 1 cm cell (a few centroids near voxel faces share a cell: the best of them).
  const CellMap decoded = by_cell(d.cloud, config.quantum);
  double worst = 0.0, worst_i = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    const auto [lo, hi] = decoded.equal_range(cell_of(p, config.quantum));
    REQUIRE(lo != hi);
    double best = 1e9, best_i = 1e9;
    for (auto it = lo; it != hi; ++it) {
      // Points of one cell decode to the same coordinates: the twin is the one with the nearest intensity.
      const double e = static_cast<double>((it->second.first - p).cwiseAbs().maxCoeff());
      const double ei = static_cast<double>(std::abs(it->second.second - cloud.intensity[i]));
      if (e < best || (e == best && ei < best_i)) {
        best = e;
        best_i = ei;
      }
    }
    worst = std::max(worst, best);
    worst_i = std::max(worst_i, best_i);
  }
  CHECK(worst <= config.quantum / 2 + 1e-5);
  CHECK(worst_i <= max_i / 65535.0 + 1e-6);
  const double bytes_per_point = static_cast<double>(blob.size()) / static_cast<double>(cloud.size());
  INFO("points " << cloud.size() << ", bytes " << blob.size() << " (" << bytes_per_point << " a point)");
  CHECK(bytes_per_point < 6.0);  // 16 bytes a point raw (3 floats + intensity)
}

TEST_CASE("map cloud: reduce_to_map_cloud crops by range and keeps one centroid per voxel") {
  PointCloud scan;
  for (int i = 0; i < 10; ++i) {
    scan.points.emplace_back(5.0f + 0.01f * static_cast<float>(i), 0.01f, 0.01f);  // one 0.15 m voxel
    scan.intensity.push_back(static_cast<float>(i));
  }
  scan.points.emplace_back(0.5f, 0.f, 0.f);  // nearer than min_range
  scan.points.emplace_back(80.f, 0.f, 0.f);  // farther than max_range
  scan.points.emplace_back(NAN, 0.f, 0.f);
  scan.intensity.insert(scan.intensity.end(), {1.f, 1.f, 1.f});
  const PointCloud out = reduce_to_map_cloud(scan, MapCloudConfig{});
  REQUIRE(out.size() == 1);
  CHECK(out.points[0].x() == Approx(5.045f).margin(1e-4));
  CHECK(out.intensity[0] == Approx(4.5f));
}

TEST_CASE("map cloud: an empty cloud and a cloud without intensity round-trip") {
  const DecodedMapCloud empty = decode_map_cloud(encode_map_cloud(PointCloud{}, 0.01));
  REQUIRE(empty.ok);
  CHECK(empty.cloud.empty());
  PointCloud c;
  c.points = {{1.f, 2.f, 3.f}, {-4.f, 5.5f, -0.25f}};
  const DecodedMapCloud d = decode_map_cloud(encode_map_cloud(c, 0.01));
  REQUIRE(d.ok);
  CHECK_FALSE(d.cloud.has_intensity());
  CHECK(d.cloud.points[0].isApprox(Eigen::Vector3f(-4.f, 5.5f, -0.25f)));
  CHECK(d.cloud.points[1].isApprox(Eigen::Vector3f(1.f, 2.f, 3.f)));
}

TEST_CASE("map cloud: hostile blobs are refused with a reason, never a crash") {
  const std::vector<std::uint8_t> good = encode_map_cloud(town_map_cloud(), 0.01);
  auto refused = [](std::vector<std::uint8_t> b, const std::string& why) {
    const DecodedMapCloud d = decode_map_cloud(b);
    INFO(d.error);
    CHECK_FALSE(d.ok);
    CHECK(d.error.rfind("map cloud: ", 0) == 0);
    CHECK(d.error.find(why) != std::string::npos);
  };
  refused({}, "shorter than its header");
  refused(std::vector<std::uint8_t>(good.begin(), good.begin() + 20), "shorter than its header");
  auto b = good;
  b[0] = 'X';
  refused(b, "wrong magic");
  b = good;
  b[4] = 9;
  refused(b, "version 9");
  b = good;
  b[8] = b[9] = b[10] = b[11] = 0xff;  // quantum NaN
  refused(b, "bad quantum");
  b = good;
  b[20] = 0x7f;  // ~2^30 points
  refused(b, "over the limit");
  b = good;
  b[17] ^= 1;  // one point more or less than the payload holds
  refused(b, "does not hold exactly");
  refused(std::vector<std::uint8_t>(good.begin(), good.end() - 10), "zstd");
  b = good;
  b.push_back(0);
  refused(b, "zstd");
  // Random corruption: always a clean answer.
  std::mt19937 rng(3);
  for (int trial = 0; trial < 300; ++trial) {
    b = good;
    for (int k = 0; k < 4; ++k) b[rng() % b.size()] = static_cast<std::uint8_t>(rng());
    const DecodedMapCloud d = decode_map_cloud(b);
    CHECK(d.ok == d.error.empty());
  }
}
