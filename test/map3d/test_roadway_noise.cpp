// Roadway-section noise removal (Ren 2019, Sec. 3.5) on synthetic roadways: noise inside a tunnel removed, its
// surfaces and the side tunnel behind an opening kept, an open street left alone, the skip rules, config validation.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/map3d/point_mask.hpp"
#include "loopd/map3d/roadway_noise.hpp"
#include "map3d/roadway_scene.hpp"

using namespace loopd;

namespace {
struct LabelCounts {
  std::size_t total[4] = {0, 0, 0, 0}, removed[4] = {0, 0, 0, 0};
  double removed_share(roadway_scene::Label l) const { return total[l] ? static_cast<double>(removed[l]) / static_cast<double>(total[l]) : 0.0; }
};

LabelCounts count_by_label(const roadway_scene::Scene& scene, const RoadwayNoiseResult& result) {
  LabelCounts counts;
  for (std::size_t i = 0; i < scene.label.size(); ++i) {
    ++counts.total[scene.label[i]];
    counts.removed[scene.label[i]] += result.remove[i];
  }
  return counts;
}

std::vector<Eigen::Isometry3d> poses_at(const std::vector<Eigen::Vector3d>& positions, const std::vector<double>& yaw_deg) {
  std::vector<Eigen::Isometry3d> poses;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(yaw_deg[i] * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = positions[i];
    poses.push_back(T);
  }
  return poses;
}
}  // namespace

TEST_CASE("Roadway noise: dust and a person inside a straight tunnel are removed, its surfaces kept") {
  const bool arched = GENERATE(false, true);
  roadway_scene::Spec spec;
  spec.arched = arched;
  const auto scene = roadway_scene::build(spec);
  const RoadwayNoiseResult result = find_roadway_noise(scene.map, scene.T_world_keyframe, RoadwayNoiseConfig{});
  const LabelCounts counts = count_by_label(scene, result);
  INFO("arched " << arched << ": stations " << result.stations << ", tunnel " << result.tunnel_stations << ", noise removed "
                 << counts.removed[roadway_scene::kNoise] << "/" << counts.total[roadway_scene::kNoise] << ", surface removed "
                 << counts.removed[roadway_scene::kSurface] << "/" << counts.total[roadway_scene::kSurface]);
  REQUIRE(result.error.empty());
  CHECK(result.stations == 150);  // 30 steps of 2 m, 5 stations each
  CHECK(result.tunnel_stations >= 0.95 * result.stations);
  CHECK(result.skipped_step + result.skipped_curvature + result.skipped_heading == 0);
  CHECK(counts.removed_share(roadway_scene::kNoise) >= 0.95);
  CHECK(counts.removed_share(roadway_scene::kSurface) <= 0.005);
  std::size_t removed = 0, tunnel_surface = 0, track_surface = 0;
  for (std::size_t i = 0; i < scene.label.size(); ++i) {
    removed += result.remove[i];
    const bool on_track = scene.map.points[i].x() > 0.5f && scene.map.points[i].x() < 59.5f;
    if (scene.label[i] != roadway_scene::kSurface || !on_track) continue;
    ++track_surface;
    tunnel_surface += result.in_tunnel[i];
  }
  CHECK(result.removed == removed);
  CHECK(tunnel_surface >= 0.95 * static_cast<double>(track_surface));
}

TEST_CASE("Roadway noise: the side tunnel behind a wall opening is kept") {
  roadway_scene::Spec spec;
  spec.side_opening = true;
  const auto scene = roadway_scene::build(spec);
  const RoadwayNoiseResult result = find_roadway_noise(scene.map, scene.T_world_keyframe, RoadwayNoiseConfig{});
  const LabelCounts counts = count_by_label(scene, result);
  INFO("stations " << result.stations << ", tunnel " << result.tunnel_stations << ", side removed " << counts.removed[roadway_scene::kSideTunnel]
                   << "/" << counts.total[roadway_scene::kSideTunnel] << ", noise removed " << counts.removed[roadway_scene::kNoise] << "/"
                   << counts.total[roadway_scene::kNoise]);
  REQUIRE(counts.total[roadway_scene::kSideTunnel] > 10000);
  CHECK(counts.removed[roadway_scene::kSideTunnel] == 0);
  CHECK(counts.removed_share(roadway_scene::kSurface) <= 0.005);
  CHECK(result.not_enclosed > 0);  // the stations in the opening see no left wall
  CHECK(counts.removed_share(roadway_scene::kNoise) >= 0.85);
}

TEST_CASE("Roadway noise: an open street (no roof) has no tunnel station and loses no point") {
  roadway_scene::Spec spec;
  spec.roof = false;
  const auto scene = roadway_scene::build(spec);
  const RoadwayNoiseResult result = find_roadway_noise(scene.map, scene.T_world_keyframe, RoadwayNoiseConfig{});
  CHECK(result.stations == 150);
  CHECK(result.tunnel_stations == 0);
  CHECK(result.not_enclosed == 150);
  CHECK(result.removed == 0);
  CHECK(result.remove == std::vector<std::uint8_t>(scene.map.size(), 0));
  CHECK(result.in_tunnel == std::vector<std::uint8_t>(scene.map.size(), 0));
}

TEST_CASE("Roadway noise: the skip rules (step length, curvature, heading) count the steps they skip") {
  const PointCloud empty;
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> yaw;
  SECTION("a 10 m jump") {
    for (double x = 0; x <= 20; x += 2) positions.emplace_back(x, 0, 1.8);
    for (double x = 30; x <= 40; x += 2) positions.emplace_back(x, 0, 1.8);
    yaw.assign(positions.size(), 0.0);
    const auto result = find_roadway_noise(empty, poses_at(positions, yaw), RoadwayNoiseConfig{});
    CHECK(result.skipped_step == 1);
    CHECK(result.skipped_curvature == 0);
    CHECK(result.skipped_heading == 0);
    CHECK(result.stations == 15 * 5);
    CHECK(result.not_enclosed == result.stations);  // nothing to fit in an empty map
  }
  SECTION("a 90 degree kink") {
    for (double x = 0; x <= 20; x += 2) positions.emplace_back(x, 0, 1.8), yaw.push_back(0.0);
    for (double y = 2; y <= 20; y += 2) positions.emplace_back(20, y, 1.8), yaw.push_back(90.0);
    const auto result = find_roadway_noise(empty, poses_at(positions, yaw), RoadwayNoiseConfig{});
    CHECK(result.skipped_step == 0);
    CHECK(result.skipped_curvature == 1);
    CHECK(result.skipped_heading == 0);
    CHECK(result.stations == 19 * 5);  // 20 steps, one skipped
  }
  SECTION("a keyframe heading 45 degrees off its step") {
    for (double x = 0; x <= 20; x += 2) positions.emplace_back(x, 0, 1.8), yaw.push_back(x == 10 ? 45.0 : 0.0);
    const auto result = find_roadway_noise(empty, poses_at(positions, yaw), RoadwayNoiseConfig{});
    CHECK(result.skipped_step == 0);
    CHECK(result.skipped_curvature == 0);
    CHECK(result.skipped_heading == 1);
    CHECK(result.stations == 9 * 5);
  }
}

TEST_CASE("Roadway noise: the same masks with 1 and 2 threads") {
  roadway_scene::Spec spec;
  spec.x_begin = -2, spec.x_end = 22, spec.track_end = 20;
  const auto scene = roadway_scene::build(spec);
  RoadwayNoiseConfig config;
  config.num_threads = 1;
  const auto serial = find_roadway_noise(scene.map, scene.T_world_keyframe, config);
  config.num_threads = 2;
  const auto parallel = find_roadway_noise(scene.map, scene.T_world_keyframe, config);
  CHECK(serial.removed > 0);
  CHECK(serial.remove == parallel.remove);
  CHECK(serial.in_tunnel == parallel.in_tunnel);
  CHECK(serial.tunnel_stations == parallel.tunnel_stations);
}

TEST_CASE("RoadwayNoiseConfig::validate rejects bad settings with a message, and find_roadway_noise then removes nothing") {
  CHECK_FALSE(RoadwayNoiseConfig{}.validate());
  RoadwayNoiseConfig config;
  config.section_thickness = 0;
  REQUIRE(config.validate());
  CHECK(config.validate()->find("section_thickness") != std::string::npos);
  config = RoadwayNoiseConfig{};
  config.section_radius = -1;
  CHECK(config.validate()->find("section_radius") != std::string::npos);
  config = RoadwayNoiseConfig{};
  config.min_inlier_share = 1.5;
  CHECK(config.validate()->find("min_inlier_share") != std::string::npos);
  config = RoadwayNoiseConfig{};
  config.fit_thickness = 0.2;
  CHECK(config.validate()->find("fit_thickness") != std::string::npos);
  config = RoadwayNoiseConfig{};
  config.station_spacing = std::nan("");
  CHECK(config.validate()->find("station_spacing") != std::string::npos);

  PointCloud map;
  map.points.assign(10, Eigen::Vector3f(1, 0, 0));
  config.section_thickness = -0.4;
  const auto result = find_roadway_noise(map, {Eigen::Isometry3d::Identity()}, config);
  CHECK_FALSE(result.error.empty());
  CHECK(result.remove == std::vector<std::uint8_t>(10, 0));
  CHECK(result.in_tunnel.size() == 10);
}

TEST_CASE("remove_points drops the marked points and keeps the attributes aligned") {
  PointCloud cloud;
  for (int i = 0; i < 5; ++i) {
    cloud.points.emplace_back(static_cast<float>(i), 0.f, 0.f);
    cloud.intensity.push_back(static_cast<float>(10 * i));
    cloud.ring.push_back(static_cast<std::uint16_t>(i));
    cloud.time.push_back(0.1f * static_cast<float>(i));
  }
  cloud.num_rings = 16;
  const PointCloud kept = remove_points(cloud, {0, 1, 0, 1, 0});
  REQUIRE(kept.size() == 3);
  CHECK(kept.points[1].x() == 2.f);
  CHECK(kept.intensity == std::vector<float>{0.f, 20.f, 40.f});
  CHECK(kept.ring == std::vector<std::uint16_t>{0, 2, 4});
  CHECK(kept.time[2] == cloud.time[4]);
  CHECK(kept.num_rings == 16);
  cloud.intensity.clear();
  CHECK(remove_points(cloud, {1, 0, 0, 0, 0}).intensity.empty());
  CHECK(remove_points(cloud, {1, 1}).size() == 5);  // a mask of the wrong size removes nothing
}
