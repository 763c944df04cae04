// Map quality (loopd-eval --map-cloud): nearest-reference error against a brute-force oracle, completeness, points
// left inside mover boxes, the movers file parser (good and hostile input) and the voxel accumulator.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "loopd/eval/map_quality.hpp"

using namespace loopd;

namespace {

/// n points of a fixed seed in a 20 m cube: ~1.6 m apart on average, so a 0.25 m shift keeps each point's own
/// original as its nearest reference point (almost always: the oracle decides).
PointCloud random_cloud(std::size_t n, std::uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 20.f);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) c.points.emplace_back(u(rng), u(rng), u(rng));
  return c;
}

double brute_force_mean_distance(const PointCloud& map, const PointCloud& ref) {
  double sum = 0.0;
  for (const auto& p : map.points) {
    double best = 1e300;
    for (const auto& r : ref.points) best = std::min(best, static_cast<double>((p - r).norm()));
    sum += best;
  }
  return sum / static_cast<double>(map.size());
}

std::string parse_error(const std::string& text) {
  std::vector<MapMoverBox> boxes(1);
  const auto error = parse_movers_json(text, &boxes);
  CHECK(boxes.size() == 1);  // untouched on failure
  return error.value_or("");
}

}  // namespace

TEST_CASE("map_quality: a map shifted by 0.25 m has the oracle's mean error, the same map has none", "[eval]") {
  const PointCloud ref = random_cloud(2000);
  PointCloud shifted = ref;
  for (auto& p : shifted.points) p += Eigen::Vector3f(0.25f, 0.f, 0.f);
  const MapQuality q = map_quality(shifted, ref, {}, MapQualityConfig{});
  REQUIRE(q.mean_error);
  REQUIRE(q.p95_error);
  CHECK(q.points == 2000);
  CHECK(q.reference_points == 2000);
  CHECK(std::abs(*q.mean_error - brute_force_mean_distance(shifted, ref)) < 1e-4);
  CHECK(std::abs(*q.mean_error - 0.25) < 0.02);
  CHECK(*q.p95_error <= 0.25 + 1e-5);
  CHECK(*q.p95_error > 0.24);

  const MapQuality same = map_quality(ref, ref, {}, MapQualityConfig{});
  CHECK(*same.mean_error == Approx(0.0).margin(1e-9));
  CHECK(*same.completeness == 1.0);
  // 0.25 m is inside the 0.3 m completeness radius; 0.5 m is not.
  CHECK(*q.completeness == 1.0);
  for (auto& p : shifted.points) p += Eigen::Vector3f(0.25f, 0.f, 0.f);
  CHECK(*map_quality(shifted, ref, {}, MapQualityConfig{}).completeness < 0.05);
}

TEST_CASE("map_quality: half the reference is about half complete, empty clouds give no error figures", "[eval]") {
  const PointCloud ref = random_cloud(2000);
  PointCloud half;
  half.points.assign(ref.points.begin(), ref.points.begin() + 1000);
  const MapQuality q = map_quality(half, ref, {}, MapQualityConfig{});
  REQUIRE(q.completeness);
  CHECK(std::abs(*q.completeness - 0.5) < 0.02);
  CHECK(*q.mean_error == Approx(0.0).margin(1e-9));

  const MapQuality empty_map = map_quality(PointCloud{}, ref, {}, MapQualityConfig{});
  CHECK_FALSE(empty_map.mean_error);
  CHECK(*empty_map.completeness == 0.0);
  CHECK(empty_map.moving_points_share == 0.0);
  const MapQuality empty_ref = map_quality(ref, PointCloud{}, {}, MapQualityConfig{});
  CHECK_FALSE(empty_ref.mean_error);
  CHECK_FALSE(empty_ref.completeness);
  CHECK(empty_ref.points == 2000);

  // Non-finite points are not evaluated.
  PointCloud with_nan = half;
  with_nan.points.emplace_back(NAN, 0.f, 0.f);
  with_nan.points.emplace_back(0.f, INFINITY, 0.f);
  CHECK(map_quality(with_nan, ref, {}, MapQualityConfig{}).points == 1000);
  CHECK(MapQualityConfig{}.validate() == std::nullopt);
  CHECK(MapQualityConfig{0.0, 0.1}.validate());
  CHECK(MapQualityConfig{0.3, -1.0}.validate());
}

TEST_CASE("map_quality: moving points are exactly the map points inside the grown mover boxes", "[eval]") {
  std::vector<MapMoverBox> movers(2);
  movers[0].min = {0, 0, 0};
  movers[0].max = {4, 2, 1.5};
  movers[1].min = {10, 10, 0};
  movers[1].max = {12, 11, 1.5};
  PointCloud map;
  map.points = {{1, 1, 1},     {3.9f, 0.1f, 0.2f}, {11, 10.5f, 1},  // inside
                {4.05f, 1, 1}, {-0.05f, 1, 1},                      // inside the 0.1 m margin
                {4.2f, 1, 1},  {11, 10.5f, 1.7f},  {6, 6, 0},       // outside
                {NAN, 1, 1}};
  const MapQuality q = map_quality(map, map, movers, MapQualityConfig{});
  CHECK(q.points == 8);
  CHECK(q.moving_points == 5);
  CHECK(q.moving_points_share == Approx(5.0 / 8.0));
  CHECK(count_mover_points(map, movers, 0.0) == 3);
  CHECK(count_mover_points(map, {}, 0.1) == 0);
  // Where the object stands at the drive's end (left false) is the final scene: a point there is not counted, even
  // inside a box it left too (a car moved along the kerb by less than its length).
  movers.push_back(MapMoverBox{});
  movers[2].min = {2, 0, 0};
  movers[2].max = {6, 2, 1.5};
  movers[2].left = false;
  CHECK(count_mover_points(map, movers, 0.0) == 2);  // (3.9, 0.1, 0.2) now lies where the car stands
}

TEST_CASE("parse_movers_json: the loopd-sim movers file, and hostile input rejected with a clear error", "[eval]") {
  std::vector<MapMoverBox> boxes;
  const std::string good = R"({"format":"loopd-movers","version":1,"movers":[{"id":3,"variant":0,"min":[1,2,0],"max":[5.5,4,1.6]},)"
                           R"({"id":3,"variant":1,"min":[-10,2e1,0.0],"max":[-6,22,1.6],"extra":"ignored"}]})";
  REQUIRE(parse_movers_json(good, &boxes) == std::nullopt);
  REQUIRE(boxes.size() == 2);
  CHECK(boxes[0].id == 3);
  CHECK(boxes[1].variant == 1);
  CHECK(boxes[0].max == Eigen::Vector3d(5.5, 4, 1.6));
  CHECK(boxes[1].min == Eigen::Vector3d(-10, 20, 0));
  CHECK(boxes[0].left);  // no "left": counted as an object that left
  REQUIRE(parse_movers_json(R"({"format":"loopd-movers","version":1,"movers":[{"id":1,"variant":1,"min":[0,0,0],"max":[1,1,1],"left":false}]})",
                            &boxes) == std::nullopt);
  CHECK_FALSE(boxes[0].left);
  REQUIRE(parse_movers_json(R"({"format":"loopd-movers","version":1,"movers":[]})", &boxes) == std::nullopt);
  CHECK(boxes.empty());

  const std::string head = R"({"format":"loopd-movers","version":1,"movers":[)";
  CHECK(parse_error("{\"format\":\"loopd-movers\",") == "movers file: not valid JSON");
  CHECK(parse_error("") == "movers file: not valid JSON");
  CHECK(parse_error("[1,2]") == "movers file: not a JSON object");
  CHECK(parse_error(R"({"format":"other","version":1,"movers":[]})") == "movers file: 'format' is not \"loopd-movers\"");
  CHECK(parse_error(R"({"format":"loopd-movers","version":2,"movers":[]})") == "movers file: version 2 is not supported (expected 1)");
  CHECK(parse_error(R"({"format":"loopd-movers","version":"1","movers":[]})") == "movers file.version: not an integer");
  CHECK(parse_error(R"({"format":"loopd-movers","version":1,"movers":{}})") == "movers file: 'movers' is not an array");
  CHECK(parse_error(head + "7]}") == "movers[0]: not an object");
  CHECK(parse_error(head + R"({"variant":0,"min":[0,0,0],"max":[1,1,1]}]})") == "movers[0]: no 'id'");
  CHECK(parse_error(head + R"({"id":-1,"variant":0,"min":[0,0,0],"max":[1,1,1]}]})") == "movers[0].id: -1 is out of range [0, 2147483647]");
  CHECK(parse_error(head + R"({"id":1,"variant":18446744073709551615,"min":[0,0,0],"max":[1,1,1]}]})") ==
        "movers[0].variant: 18446744073709551615 is out of range");
  CHECK(parse_error(head + R"({"id":1.5,"variant":0,"min":[0,0,0],"max":[1,1,1]}]})") == "movers[0].id: not an integer");
  CHECK(parse_error(head + R"({"id":1,"variant":0,"min":[0,0],"max":[1,1,1]}]})") == "movers[0].min: not an array of 3 numbers");
  CHECK(parse_error(head + R"({"id":1,"variant":0,"min":[0,0,0],"max":[1,"1",1]}]})") == "movers[0].max[1]: not a finite number");
  CHECK(parse_error(head + R"({"id":1,"variant":0,"min":[0,0,0],"max":[1,1,1e999]}]})") == "movers file: not valid JSON");
  CHECK(parse_error(head + R"({"id":1,"variant":0,"min":[0,0,0],"max":[1,1,1]},{"id":2,"variant":0,"min":[0,5,0],"max":[1,1,1]}]})") ==
        "movers[1]: min[1] is greater than max[1]");
  CHECK(parse_error(std::string(100000, '[')) == "movers file: not valid JSON");
  CHECK(parse_error(head + R"({"id":1,"variant":0,"min":[0,0,0],"max":[1,1,1],"left":1}]})") == "movers[0].left: not a boolean");
}

TEST_CASE("VoxelAccumulator: the points of one voxel merge into their centroid, with their mean intensity", "[eval]") {
  VoxelAccumulator acc(0.5);
  acc.add({0.1f, 0.1f, 0.1f}, 10.f);
  acc.add({0.3f, 0.4f, 0.2f}, 20.f);
  acc.add({0.2f, 0.1f, 0.45f}, 30.f);
  acc.add({-0.1f, 0.1f, 0.1f}, 5.f);  // another voxel: floor(-0.2) = -1
  acc.add({NAN, 0.f, 0.f}, 1.f);      // skipped
  acc.add({1e12f, 0.f, 0.f}, 1.f);    // skipped: beyond 2^30 voxels
  CHECK(acc.size() == 2);
  CHECK(acc.points_added() == 4);
  CHECK(acc.points_skipped() == 2);
  const PointCloud c = acc.cloud();
  REQUIRE(c.size() == 2);
  REQUIRE(c.has_intensity());
  // Ordered by key: (-1, 0, 0) first.
  CHECK(c.points[0].isApprox(Eigen::Vector3f(-0.1f, 0.1f, 0.1f)));
  CHECK(c.intensity[0] == 5.f);
  CHECK(c.points[1].isApprox(Eigen::Vector3f(0.2f, 0.2f, 0.25f), 1e-6f));
  CHECK(c.intensity[1] == Approx(20.0));
  CHECK(VoxelAccumulator(0.2).cloud().empty());
}
