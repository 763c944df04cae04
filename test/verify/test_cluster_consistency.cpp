#include <catch2/catch.hpp>

#include "loopd/base/pose.hpp"
#include "loopd/verify/cluster_consistency.hpp"

using namespace loopd;

namespace {
Cluster compact(float x, float y, float z = 1.0f, float extent = 2.0f) {
  Cluster c;
  c.centroid = Eigen::Vector3f(x, y, z);
  c.num_points = 100;
  c.extent_major = extent;
  c.extent_minor = extent / 2;
  return c;
}
Segmentation scene(const Eigen::Isometry3d& T_sensor_world) {
  // Objects in the world frame, expressed in the sensor frame.
  const std::vector<Eigen::Vector3f> objects = {{5, 3, 1}, {-4, 6, 1}, {12, -5, 1}, {-10, -8, 2}, {20, 7, 1}, {3, -15, 1}, {-18, 2, 3}, {25, -12, 1}};
  Segmentation s;
  for (const auto& o : objects) {
    const Eigen::Vector3f p = T_sensor_world.cast<float>() * o;
    s.clusters.push_back(compact(p.x(), p.y(), p.z()));
  }
  Cluster ground = compact(0, 0, -1.7f, 60.0f);  // extended: ignored by rule 1
  s.clusters.push_back(ground);
  return s;
}
}  // namespace

TEST_CASE("cluster consistency is 1 for the same objects seen from another pose") {
  const Eigen::Isometry3d T_world_query = make_isometry(2, -1, 0, 2.5);
  const Eigen::Isometry3d T_world_match = make_isometry(-1, 2, 0, -0.4);
  const Segmentation q = scene(T_world_query.inverse());
  const Segmentation m = scene(T_world_match.inverse());
  const Eigen::Isometry3d T_match_query = T_world_match.inverse() * T_world_query;
  const auto r = cluster_consistency(q, m, T_match_query, ClusterConsistencyConfig{});
  CHECK(r.num_query == 8);
  CHECK(r.num_match == 8);
  CHECK(r.num_matched == 8);
  CHECK(r.consistency == Approx(1.0));
  CHECK(r.mean_distance == Approx(0.0).margin(1e-4));
}

TEST_CASE("cluster consistency falls under a wrong alignment (3 m off)") {
  const Segmentation q = scene(Eigen::Isometry3d::Identity());
  const Segmentation m = scene(Eigen::Isometry3d::Identity());
  const auto r = cluster_consistency(q, m, make_isometry(3, 0, 0, 0.0), ClusterConsistencyConfig{});
  CHECK(r.consistency < 0.3);
}

TEST_CASE("cluster consistency survives moved parked cars (share over the smaller set)") {
  Segmentation q = scene(Eigen::Isometry3d::Identity());
  Segmentation m = scene(Eigen::Isometry3d::Identity());
  // Two cars left, one car parked elsewhere in the match; one new car in the query.
  m.clusters.erase(m.clusters.begin() + 1, m.clusters.begin() + 3);
  m.clusters.push_back(compact(8, -3));
  q.clusters.push_back(compact(-6, -3));
  const auto r = cluster_consistency(q, m, Eigen::Isometry3d::Identity(), ClusterConsistencyConfig{});
  CHECK(r.num_query == 9);
  CHECK(r.num_match == 7);
  CHECK(r.num_matched == 6);
  CHECK(r.consistency == Approx(6.0 / 7.0));
}

TEST_CASE("cluster consistency ignores objects outside the common view and reports too few clusters") {
  Segmentation q, m;
  q.clusters = {compact(5, 0), compact(100, 0)};
  m.clusters = {compact(5, 0)};
  const auto r = cluster_consistency(q, m, Eigen::Isometry3d::Identity(), ClusterConsistencyConfig{});
  CHECK(r.num_query == 1);
  CHECK(r.consistency == -1.0);
  CHECK_FALSE(r.reason.empty());
  ClusterConsistencyConfig bad;
  bad.match_distance = 0;
  CHECK(bad.validate());
  CHECK(cluster_consistency(q, m, Eigen::Isometry3d::Identity(), bad).consistency == -1.0);
}
