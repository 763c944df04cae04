// Map building: keyframe clouds merged through the occupancy octree at their poses. What a later scan sees through
// (an object that left) is dropped; static surfaces, the ground seen at grazing angles included, stay.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <unistd.h>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/map3d/key_sort.hpp"
#include "loopd/map3d/map_builder.hpp"
#include "loopd/map3d/occupancy_map.hpp"

using namespace loopd;

namespace {

/// A sensor 1.8 m above a flat ground at x = sensor_x: a ground disc (0.1 m grid to 25 m), a wall at y = 8 (x in
/// [-30, 30], z in [0, 4]) and, when `box`, a 2 x 1 x 1.5 m "parked car" at x in [4, 6], y in [2, 3] (sensor frame).
PointCloud scene_scan(double sensor_x, bool box) {
  PointCloud c;
  const float h = 1.8f, sx = static_cast<float>(sensor_x);
  for (float x = -25.f; x <= 25.f; x += 0.1f)
    for (float y = -7.9f; y <= 7.9f; y += 0.1f)
      if (x * x + y * y > 4.f && x * x + y * y < 625.f && !(box && x + sx >= 4.f && x + sx <= 6.f && y >= 2.f && y <= 3.f))
        c.points.emplace_back(x, y, -h);
  for (float x = -30.f; x <= 30.f; x += 0.1f)
    for (float z = 0.f; z <= 4.f; z += 0.1f) c.points.emplace_back(x - sx, 8.f, z - h);
  if (box)
    for (float x = 4.f; x <= 6.f; x += 0.1f)
      for (float z = 0.f; z <= 1.5f; z += 0.1f) c.points.emplace_back(x - sx, 2.f, z - h);  // the face toward the sensor
  c.intensity.assign(c.size(), 0.5f);
  return voxel_downsample(c, 0.15);
}

struct Scene {
  std::vector<MapBuildKeyframe> keyframes;
  std::map<std::int64_t, PointCloud> clouds;
};

/// Keyframes every 2 m along x from -10 to 10: the box stands there for the first three, then it is gone (OctoMap's
/// clamped log-odds: three hits are undone by about seven misses).
Scene drive_past_box() {
  Scene s;
  for (int i = 0; i <= 10; ++i) {
    const double x = -10.0 + 2.0 * i;
    MapBuildKeyframe k;
    k.key = KeyframeKey{0, i};
    k.T_map_sensor.translation() = Eigen::Vector3d(x, 0.0, 1.8);
    s.keyframes.push_back(k);
    s.clouds[i] = scene_scan(x, i < 3);
  }
  return s;
}

MapCloudSource source(const Scene& s) {
  return [&s](const KeyframeKey& key) -> std::optional<PointCloud> { return s.clouds.at(key.index); };
}

bool in_box(const Eigen::Vector3f& p) { return p.x() >= 3.9f && p.x() <= 6.1f && p.y() >= 1.9f && p.y() <= 2.2f && p.z() > 0.35f && p.z() <= 1.6f; }
bool on_wall(const Eigen::Vector3f& p) { return std::abs(p.y() - 8.f) < 0.2f && std::abs(p.x()) < 25.f; }
bool on_ground(const Eigen::Vector3f& p) { return std::abs(p.z()) < 0.15f && std::abs(p.y()) < 7.5f && std::abs(p.x()) < 25.f; }

}  // namespace

TEST_CASE("map builder: an object seen, then seen through, leaves the map, the wall and the ground stay") {
  const Scene scene = drive_past_box();
  MapBuildConfig config;
  config.roadway_noise = false;
  config.statistical_outliers = false;
  const MapBuildResult with = build_map(scene.keyframes, source(scene), config);
  config.clear_free_space = false;
  const MapBuildResult without = build_map(scene.keyframes, source(scene), config);
  auto count = [](const PointCloud& m, bool (*pred)(const Eigen::Vector3f&)) {
    std::size_t n = 0;
    for (const auto& p : m.points) n += pred(p) ? 1 : 0;
    return n;
  };
  const std::size_t box_before = count(without.map, in_box), box_after = count(with.map, in_box);
  const std::size_t wall_before = count(without.map, on_wall), wall_after = count(with.map, on_wall);
  const std::size_t ground_before = count(without.map, on_ground), ground_after = count(with.map, on_ground);
  INFO("box " << box_before << " -> " << box_after << ", wall " << wall_before << " -> " << wall_after << ", ground " << ground_before << " -> "
              << ground_after << "; cleared " << with.stats.points_cleared);
  REQUIRE(box_before > 40);
  CHECK(box_after <= box_before / 10);                                                    // the car that left is gone (its lowest row may stay)
  CHECK(static_cast<double>(wall_after) >= 0.99 * static_cast<double>(wall_before));      // nothing static behind it lost
  CHECK(static_cast<double>(ground_after) >= 0.98 * static_cast<double>(ground_before));  // grazing rays do not eat the ground
  CHECK(with.stats.keyframes == 11);
  CHECK(with.stats.keyframes_without_cloud == 0);
  CHECK(with.stats.points_out == with.map.size());
  CHECK(with.map.has_intensity());
}

TEST_CASE("map builder: keyframes without a map cloud are counted and left out, the octree writes a .bt") {
  Scene scene = drive_past_box();
  const MapCloudSource some = [&scene](const KeyframeKey& key) -> std::optional<PointCloud> {
    if (key.index % 2 == 1) return std::nullopt;
    return scene.clouds.at(key.index);
  };
  MapBuildConfig config;
  const MapBuildResult r = build_map(scene.keyframes, some, config);
  CHECK(r.stats.keyframes == 11);
  CHECK(r.stats.keyframes_without_cloud == 5);
  CHECK(r.map.size() > 1000);
  OccupancyMap octree(config.octree);
  MapBuildStats stats;
  insert_keyframes(scene.keyframes, some, {}, &octree, &stats);
  CHECK(stats.octree_leaves > 1000);
  const std::string path = "/tmp/loopd_test_map_builder_" + std::to_string(::getpid()) + ".bt";
  REQUIRE_FALSE(octree.write_binary(path).has_value());
  std::FILE* f = std::fopen(path.c_str(), "rb");
  REQUIRE(f);
  char head[40] = {};
  CHECK(std::fread(head, 1, sizeof head - 1, f) > 0);
  std::fclose(f);
  std::remove(path.c_str());
  CHECK(std::string(head).rfind("# Octomap OcTree binary file", 0) == 0);
  CHECK(octree.write_binary("/nonexistent-dir/map.bt").value_or("").find("cannot write /nonexistent-dir/map.bt") == 0);
  CHECK(MapBuildConfig{}.validate() == std::nullopt);
  MapBuildConfig bad;
  bad.voxel = 0.0;
  CHECK(bad.validate().value_or("").find("voxel") != std::string::npos);
}

TEST_CASE("map builder: ray keys are sorted and made unique as std::sort and std::unique do, at every size") {
  std::mt19937_64 rng(11);
  for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{4096}, std::size_t{300000}}) {
    std::vector<std::uint64_t> keys(n);
    // Repeats (a narrow range of keys) and all three 16-bit coordinates in use, the largest included.
    for (auto& k : keys) k = (rng() % 2 == 0) ? (rng() & ((std::uint64_t{1} << 48) - 1)) : (0xFFFF00000000ull | (rng() % 5000));
    if (n > 2) keys[0] = keys[n - 1] = (std::uint64_t{1} << 48) - 1;
    std::vector<std::uint64_t> want = keys;
    std::sort(want.begin(), want.end());
    want.erase(std::unique(want.begin(), want.end()), want.end());
    sort_unique_keys(&keys);
    INFO("n = " << n);
    CHECK(keys == want);
  }
}

TEST_CASE("occupancy map: free_points marks exactly the finite points at() calls free, in their order") {
  const Scene scene = drive_past_box();
  OccupancyMap octree{OccupancyMapConfig{}};
  for (const MapBuildKeyframe& k : scene.keyframes)
    octree.insert_scan(transform(scene.clouds.at(k.key.index), k.T_map_sensor), k.T_map_sensor.translation());
  // The first keyframe's cloud in the map (the box that left: free now; the wall: occupied), points in leaves never
  // reached (unknown) and points that are not finite.
  PointCloud probe = transform(scene.clouds.at(0), scene.keyframes[0].T_map_sensor);
  probe.points.emplace_back(0.f, 0.f, 500.f);
  probe.points.emplace_back(std::nanf(""), 0.f, 0.f);
  probe.points.emplace_back(5.f, 2.f, std::numeric_limits<float>::infinity());
  const std::vector<std::uint8_t> free = octree.free_points(probe);
  REQUIRE(free.size() == probe.size());
  std::size_t n_free = 0, n_occupied = 0, mismatches = 0;
  for (std::size_t i = 0; i < probe.size(); ++i) {
    const Eigen::Vector3f& p = probe.points[i];
    const bool expect = p.allFinite() && octree.at(p) == Occupancy::kFree;
    mismatches += (free[i] != 0) != expect ? 1 : 0;
    n_free += expect ? 1 : 0;
    n_occupied += p.allFinite() && octree.at(p) == Occupancy::kOccupied ? 1 : 0;
  }
  INFO(n_free << " free, " << n_occupied << " occupied of " << probe.size());
  CHECK(mismatches == 0);
  CHECK(n_free > 40);  // the box's face, seen through later
  CHECK(n_occupied > 1000);
  CHECK(free[probe.size() - 1] == 0);
  CHECK(free[probe.size() - 2] == 0);
  CHECK(free[probe.size() - 3] == 0);
}
