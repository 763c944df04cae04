// The one voxel grid (base/voxel_grid.hpp) against a brute-force map, its key range, and voxel_downsample's attributes.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <random>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/voxel_grid.hpp"

using namespace loopd;

namespace {
struct FirstIndex {
  int first = -1;
};
}  // namespace

TEST_CASE("VoxelGrid equals a brute-force map of floor keys, also when its table grows from 16 slots") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-30.f, 30.f);
  std::normal_distribution<float> blob(0.f, 0.4f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 20000; ++i) pts.emplace_back(u(rng), u(rng), u(rng));
  for (int i = 0; i < 5000; ++i) pts.emplace_back(blob(rng) + 3.f, blob(rng) - 7.f, blob(rng));  // runs of the same voxel
  const double leaf = 0.7, inv = 1.0 / leaf;
  struct Expected {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::uint32_t count = 0;
    int first = -1;
  };
  std::map<std::uint64_t, Expected> expected;  // ordered by key, as sorted_voxels() must be
  VoxelGrid<FirstIndex> grid(leaf, 1);         // 16 slots: grows ~10 times
  for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
    const Eigen::Vector3f& p = pts[static_cast<std::size_t>(i)];
    const auto cx = static_cast<std::int64_t>(std::floor(p.x() * inv)), cy = static_cast<std::int64_t>(std::floor(p.y() * inv)),
               cz = static_cast<std::int64_t>(std::floor(p.z() * inv));
    const std::uint64_t key = (static_cast<std::uint64_t>(cx + (1 << 20)) << 42) | (static_cast<std::uint64_t>(cy + (1 << 20)) << 21) |
                              static_cast<std::uint64_t>(cz + (1 << 20));
    Expected& e = expected[key];
    e.sum += p.cast<double>();
    ++e.count;
    if (e.first < 0) e.first = i;
    auto* v = grid.add(p);
    REQUIRE(v != nullptr);
    if (v->count == 1) v->payload.first = i;
  }
  const auto voxels = std::move(grid).sorted_voxels();
  REQUIRE(voxels.size() == expected.size());
  std::size_t k = 0;
  for (const auto& [key, e] : expected) {
    const auto& v = voxels[k++];
    CHECK(v.key == key);
    CHECK(v.count == e.count);
    CHECK(v.payload.first == e.first);
    CHECK(v.sum == e.sum);  // same additions in the same order: exactly equal
    CHECK(v.centroid() == (e.sum / static_cast<double>(e.count)).cast<float>());
  }
}

TEST_CASE("voxel_key floors negative coordinates and accepts exactly the voxels -2^20 .. 2^20 - 1") {
  std::uint64_t key = 0;
  REQUIRE(voxel_key(Eigen::Vector3f(-0.1f, 0.1f, 0.f), 1.0, &key));
  CHECK(key >> 42 == (1u << 20) - 1);                   // floor(-0.1) = -1
  CHECK(((key >> 21) & ((1u << 21) - 1)) == 1u << 20);  // floor(0.1) = 0
  const float edge = static_cast<float>(1 << 20);
  CHECK(voxel_key(Eigen::Vector3f(-edge, 0.f, 0.f), 1.0, &key));
  CHECK(key >> 42 == 0);
  CHECK_FALSE(voxel_key(Eigen::Vector3f(edge, 0.f, 0.f), 1.0, &key));
  CHECK_FALSE(voxel_key(Eigen::Vector3f(0.f, 0.f, -edge - 1.f), 1.0, &key));
  CHECK(voxel_key(Eigen::Vector3f(0.f, 0.f, edge - 1.f), 1.0, &key));
}

TEST_CASE("voxel_downsample averages intensity, keeps the first point's ring and drops points beyond the key range") {
  PointCloud c;
  c.points = {{0.2f, 0.2f, 0.2f}, {5.5f, 0.f, 0.f}, {0.6f, 0.4f, 0.2f}, {1e30f, 0.f, 0.f}, {-1e30f, 1.f, 1.f}, {3e6f, 0.f, 0.f}};
  c.intensity = {10.f, 7.f, 20.f, 1.f, 1.f, 1.f};
  c.ring = {3, 5, 9, 1, 1, 1};
  c.num_rings = 16;
  const PointCloud d = voxel_downsample(c, 1.0);
  REQUIRE(d.size() == 2);
  CHECK(d.points[0].x() == Approx(0.4f));
  CHECK(d.intensity[0] == Approx(15.f));
  CHECK(d.ring[0] == 3);
  CHECK(d.points[1].x() == Approx(5.5f));
  CHECK(d.intensity[1] == Approx(7.f));
  CHECK(d.ring[1] == 5);
  CHECK(d.num_rings == 16);
}
