// Range-image segmentation (Vlaminck 2019, Sec. 4.2.1) on simulated scans of the procedural town.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/base/lidar_model.hpp"
#include "loopd/segmentation/segmentation.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

using namespace loopd;

namespace {
struct PlaneCounts {
  int ground = 0;    // horizontal planes below the sensor
  int vertical = 0;  // facades, walls
};

PlaneCounts count_planes(const Segmentation& s) {
  PlaneCounts c;
  for (const auto& cl : s.clusters) {
    if (!cl.planar) continue;
    if (std::abs(cl.plane.z()) > 0.95f && cl.centroid.z() < -1.0f) ++c.ground;
    if (std::abs(cl.plane.z()) < 0.2f) ++c.vertical;
  }
  return c;
}

PointCloud town_scan(const LidarModel& model, int visit = 0) {
  static const Town town = make_town(1);
  return simulate_scan(town, model, street_pose(town, 1, 1, 1, 25.0), 7, 1, visit);
}
}  // namespace

TEST_CASE("SegmentationConfig::validate rejects bad settings") {
  SegmentationConfig c;
  CHECK_FALSE(c.validate());
  c.max_normal_angle_deg = 95;
  CHECK(c.validate());
  c = SegmentationConfig{};
  c.min_cluster_points = 1;
  CHECK(c.validate());
  c = SegmentationConfig{};
  c.max_range = 0.5;
  CHECK(c.validate());
}

TEST_CASE("segment finds the ground and vertical facades in an HDL-64E town scan") {
  const LidarModel model = lidar_model_hdl64();
  const PointCloud scan = town_scan(model);
  REQUIRE(scan.has_rings());
  const Segmentation s = segment(scan, &model, SegmentationConfig{});
  REQUIRE(s.error.empty());
  const PlaneCounts pc = count_planes(s);
  CHECK(pc.ground >= 1);
  CHECK(pc.vertical >= 4);
  // Clusters are sorted by size and the largest is the ground around the sensor.
  for (std::size_t i = 1; i < s.clusters.size(); ++i) CHECK(s.clusters[i - 1].num_points >= s.clusters[i].num_points);
  CHECK(std::abs(s.clusters[0].plane.z()) > 0.95f);
  const SegmentationConfig cfg;
  for (const auto& cl : s.clusters) {
    CHECK(static_cast<int>(cl.points.size()) <= cfg.max_kept_points_per_cluster);
    CHECK(cl.num_points >= cfg.min_cluster_points);
    if (!cl.planar) {
      CHECK(cl.hull.empty());
      continue;
    }
    CHECK(cl.plane.head<3>().norm() == Approx(1.0f).epsilon(1e-4));
    CHECK(cl.hull.size() >= 3);
    CHECK(static_cast<int>(cl.hull.size()) <= cfg.max_hull_points);
    // Hull vertices are member points: on the plane within a few plane-fit tolerances.
    INFO("cluster n=" << cl.num_points << " normal " << cl.plane.head<3>().transpose() << " centroid " << cl.centroid.transpose() << " extent "
                      << cl.extent_major);
    for (const auto& h : cl.hull) CHECK(std::abs(cl.plane.head<3>().dot(h) + cl.plane.w()) < 3 * cfg.plane_rms_tolerance + 1e-3);
  }
  // Memory: the segmentation stays a small part of a keyframe's ~120 KB budget.
  CHECK(s.bytes() < 50 * 1024);
}

TEST_CASE("rings from the scan, from the lidar model and from binned elevations give the same structure") {
  const LidarModel model = lidar_model_hdl64();
  PointCloud scan = town_scan(model);
  const Segmentation with_rings = segment(scan, nullptr, SegmentationConfig{});
  scan.ring.clear();
  scan.num_rings = 0;
  const Segmentation from_model = segment(scan, &model, SegmentationConfig{});
  const Segmentation from_bins = segment(scan, nullptr, SegmentationConfig{});
  for (const Segmentation* s : {&with_rings, &from_model, &from_bins}) {
    REQUIRE(s->error.empty());
    const PlaneCounts pc = count_planes(*s);
    CHECK(pc.ground >= 1);
    CHECK(pc.vertical >= 4);
  }
}

TEST_CASE("HDL-32E and VLP-16 scans are segmented into planes too") {
  for (const LidarModel& model : {lidar_model_hdl32(), lidar_model_vlp16()}) {
    INFO(model.name);
    const Segmentation s = segment(town_scan(model), &model, SegmentationConfig{});
    REQUIRE(s.error.empty());
    const PlaneCounts pc = count_planes(s);
    CHECK(pc.ground >= 1);
    CHECK(pc.vertical >= 3);
  }
}

TEST_CASE("segment is deterministic") {
  const LidarModel model = lidar_model_hdl32();
  const PointCloud scan = town_scan(model);
  const Segmentation a = segment(scan, nullptr, SegmentationConfig{});
  const Segmentation b = segment(scan, nullptr, SegmentationConfig{});
  REQUIRE(a.clusters.size() == b.clusters.size());
  for (std::size_t i = 0; i < a.clusters.size(); ++i) {
    CHECK(a.clusters[i].num_points == b.clusters[i].num_points);
    CHECK(a.clusters[i].centroid == b.clusters[i].centroid);
    CHECK(a.clusters[i].hull == b.clusters[i].hull);
    CHECK(a.clusters[i].points == b.clusters[i].points);
  }
}

TEST_CASE("degenerate input gives an error or no planes, never a crash") {
  SegmentationConfig cfg;
  CHECK_FALSE(segment(PointCloud{}, nullptr, cfg).error.empty());
  PointCloud few;
  few.points = {{1, 2, 3}, {2, 3, 4}, {5, 1, 0}};
  CHECK_FALSE(segment(few, nullptr, cfg).error.empty());
  PointCloud nan_cloud;
  nan_cloud.points.assign(1000, Eigen::Vector3f(NAN, NAN, NAN));
  const Segmentation s_nan = segment(nan_cloud, nullptr, cfg);
  CHECK(s_nan.clusters.empty());
  // Points on a line: no plane can be fitted.
  PointCloud line;
  for (int i = 0; i < 2000; ++i) line.points.emplace_back(2.0f + 0.01f * static_cast<float>(i), 1.0f, 0.5f);
  CHECK(segment(line, nullptr, cfg).num_planar() == 0);
  cfg.min_cluster_points = 0;
  CHECK(segment(line, nullptr, cfg).error.find("invalid") != std::string::npos);
}
