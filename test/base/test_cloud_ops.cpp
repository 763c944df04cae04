#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/kdtree.hpp"
#include "loopd/base/pose.hpp"

using namespace loopd;

TEST_CASE("voxel_downsample keeps one centroid per voxel") {
  PointCloud c;
  c.points = {{0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}, {1.5f, 0.2f, 0.2f}, {NAN, 0.f, 0.f}};
  const PointCloud d = voxel_downsample(c, 1.0);
  REQUIRE(d.size() == 2);
  CHECK(d.points[0].x() == Approx(0.2f));
  CHECK(d.points[1].x() == Approx(1.5f));
}

TEST_CASE("remove_non_finite drops NaN and Inf and counts them") {
  PointCloud c;
  c.points = {{0, 0, 0}, {NAN, 1, 1}, {1, INFINITY, 0}, {2, 2, 2}};
  c.intensity = {1, 2, 3, 4};
  std::size_t removed = 0;
  const PointCloud d = remove_non_finite(c, &removed);
  CHECK(removed == 2);
  REQUIRE(d.size() == 2);
  CHECK(d.intensity[1] == 4.f);
}

TEST_CASE("interpolate is linear in translation and slerp in rotation") {
  const Eigen::Isometry3d a = make_isometry(0, 0, 0, 0.0);
  const Eigen::Isometry3d b = make_isometry(2, 4, 0, M_PI / 2);
  const Eigen::Isometry3d m = interpolate(a, b, 0.25);
  CHECK(m.translation().x() == Approx(0.5));
  CHECK(m.translation().y() == Approx(1.0));
  CHECK(rotation_angle(m) == Approx(M_PI / 8));
}

TEST_CASE("k-d tree nearest neighbour agrees with brute force") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-10, 10);
  std::vector<Eigen::Vector3f> pts(2000);
  for (auto& p : pts) p = {u(rng), u(rng), u(rng)};
  KdTree3f tree(pts);
  for (int k = 0; k < 100; ++k) {
    const Eigen::Vector3f q(u(rng), u(rng), u(rng));
    int best = -1;
    float bd = 1e30f;
    for (int i = 0; i < static_cast<int>(pts.size()); ++i)
      if ((pts[i] - q).squaredNorm() < bd) bd = (pts[i] - q).squaredNorm(), best = i;
    int idx = -1;
    float d = 0;
    REQUIRE(tree.nearest(q, &idx, &d));
    CHECK(idx == best);
    CHECK(d == Approx(bd));
  }
}
