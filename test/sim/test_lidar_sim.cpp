// Simulator: lidar models, ray-cast scans (rings, elevations, counts, determinism), overlap between visits, scenes.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/kdtree.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Share of `query` points (world frame) that have a `target` point within `radius` [m].
double overlap(const loopd::PointCloud& query, const Eigen::Isometry3d& T_wq, const loopd::PointCloud& target, const Eigen::Isometry3d& T_wt,
               double radius) {
  const loopd::PointCloud tw = loopd::transform(target, T_wt);
  const loopd::PointCloud qw = loopd::transform(query, T_wq);
  loopd::KdTree3f tree(tw.points);
  std::size_t close = 0;
  for (std::size_t i = 0; i < qw.size(); ++i) {
    int idx;
    float d2;
    if (tree.nearest(qw.points[i], &idx, &d2) && d2 <= radius * radius) ++close;
  }
  return qw.empty() ? 0.0 : static_cast<double>(close) / static_cast<double>(qw.size());
}

}  // namespace

TEST_CASE("lidar models carry their datasheet geometry", "[sim][lidar_model]") {
  const auto vlp = loopd::lidar_model_vlp16();
  CHECK(vlp.num_rings == 16);
  CHECK(vlp.vertical_angles_deg.front() == Approx(-15.0));
  CHECK(vlp.vertical_angles_deg.back() == Approx(15.0));
  CHECK(vlp.vertical_angles_deg[1] - vlp.vertical_angles_deg[0] == Approx(2.0));
  CHECK(vlp.azimuth_steps == 1800);
  CHECK(vlp.max_range == Approx(100.0));

  const auto h32 = loopd::lidar_model_hdl32();
  CHECK(h32.num_rings == 32);
  CHECK(h32.vertical_angles_deg.front() == Approx(-30.67));
  CHECK(h32.vertical_angles_deg.back() == Approx(10.67));

  const auto h64 = loopd::lidar_model_hdl64();
  CHECK(h64.num_rings == 64);
  CHECK(h64.vertical_angles_deg.front() == Approx(-24.9));
  CHECK(h64.vertical_angles_deg.back() == Approx(2.0));
  CHECK(h64.vertical_angles_deg[31] == Approx(-8.87));
  CHECK(h64.vertical_angles_deg[32] == Approx(-8.33));
  CHECK(h64.azimuth_step_deg() == Approx(0.1728).epsilon(0.001));
  CHECK(h64.max_range == Approx(120.0));

  const auto os1 = loopd::lidar_model_os1_64();
  CHECK(os1.num_rings == 64);
  CHECK(os1.vertical_angles_deg.front() == Approx(-16.6));
  CHECK(os1.vertical_angles_deg.back() == Approx(16.6));
  CHECK((os1.azimuth_steps == 1024 || os1.azimuth_steps == 2048));

  for (const auto& name : loopd::lidar_model_names()) {
    const auto m = loopd::lidar_model_from_name(name);
    REQUIRE(m);
    CHECK_FALSE(m->validate());
    CHECK(m->name == name);
    for (int r = 0; r < m->num_rings; ++r) {
      CHECK(loopd::ring_from_elevation(*m, m->vertical_angles_deg[static_cast<std::size_t>(r)] * kPi / 180.0) == r);
    }
    CHECK(loopd::ring_from_elevation(*m, (m->vertical_angles_deg.back() + 5.0) * kPi / 180.0) == -1);
    CHECK(loopd::ring_from_elevation(*m, (m->vertical_angles_deg.front() - 5.0) * kPi / 180.0) == -1);
  }
  CHECK_FALSE(loopd::lidar_model_from_name("hdl128"));
}

TEST_CASE("an HDL-64E town scan has the model's rings, elevations and a realistic point count", "[sim][scan]") {
  const loopd::Town town = loopd::make_town(1);
  const auto model = loopd::lidar_model_hdl64();
  const Eigen::Isometry3d T = loopd::street_pose(town, 0, 0, 0, 25.0);
  const loopd::PointCloud scan = loopd::simulate_scan(town, model, T, 7, 2);
  CAPTURE(scan.size());
  CHECK(scan.num_rings == 64);
  REQUIRE(scan.has_rings());
  REQUIRE(scan.has_intensity());
  CHECK(scan.size() >= 100000);
  CHECK(scan.size() <= 130000);

  std::vector<int> per_ring(64, 0);
  double worst = 0.0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto& p = scan.points[i];
    const int r = scan.ring[i];
    REQUIRE(r < 64);
    ++per_ring[static_cast<std::size_t>(r)];
    const double elev = std::atan2(p.z(), std::hypot(p.x(), p.y())) * 180.0 / kPi;
    worst = std::max(worst, std::abs(elev - model.vertical_angles_deg[static_cast<std::size_t>(r)]));
    CHECK(loopd::ring_from_elevation(model, elev * kPi / 180.0) == r);
    const double range = p.norm();
    REQUIRE(range >= model.min_range - 1e-3);
    REQUIRE(range <= model.max_range + 0.2);
    REQUIRE(scan.intensity[i] >= 0.0f);
    REQUIRE(scan.intensity[i] <= 1.0f);
  }
  CHECK(worst < 0.01);  // [deg] float rounding only
  for (int r = 0; r < 64; ++r) {
    CAPTURE(r);
    CHECK(per_ring[static_cast<std::size_t>(r)] > model.azimuth_steps / 2);
    CHECK(per_ring[static_cast<std::size_t>(r)] <= model.azimuth_steps);
  }
  // Lowest ring hits the ground ~3.9 m away (1.8 m / tan 24.9 deg) on flat-ish ground.
  double near_ground = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (scan.ring[i] == 0) {
      near_ground += std::hypot(scan.points[i].x(), scan.points[i].y());
      ++count;
    }
  }
  CHECK(near_ground / count == Approx(1.8 / std::tan(24.9 * kPi / 180.0)).margin(0.4));
}

TEST_CASE("scans are byte-identical for a seed whatever the thread count", "[sim][determinism]") {
  const loopd::Town town = loopd::make_town(3);
  const auto model = loopd::lidar_model_vlp16();
  const Eigen::Isometry3d T = loopd::street_pose(town, 1, 0, 1, 12.0);
  const auto a = loopd::simulate_scan(town, model, T, 11, 1, 2);
  const auto b = loopd::simulate_scan(town, model, T, 11, 2, 2);
  const auto c = loopd::simulate_scan(town, model, T, 12, 2, 2);
  REQUIRE(a.size() == b.size());
  CHECK(std::memcmp(a.points.data(), b.points.data(), a.size() * sizeof(Eigen::Vector3f)) == 0);
  CHECK(a.intensity == b.intensity);
  CHECK(a.ring == b.ring);
  // Another noise seed: same rays, different noise.
  bool differs = a.size() != c.size();
  for (std::size_t i = 0; !differs && i < a.size(); ++i) differs = a.points[i] != c.points[i];
  CHECK(differs);
  // Towns are deterministic too.
  const loopd::Town town2 = loopd::make_town(3);
  REQUIRE(town2.primitives.size() == town.primitives.size());
  CHECK(town2.street_x == town.street_x);
}

TEST_CASE("the same place on another visit overlaps, a place 50 m away does not", "[sim][overlap]") {
  const loopd::Town town = loopd::make_town(1);
  const auto model = loopd::lidar_model_hdl64();
  // Street (0,0) -> (1,0), eastbound lane; second visit 0.3 m further along, 0.2 m to the side, cars moved.
  const Eigen::Isometry3d Ta = loopd::street_pose(town, 0, 0, 0, 25.0, -2.0);
  const Eigen::Isometry3d Tb = loopd::street_pose(town, 0, 0, 0, 25.3, -1.8);
  const Eigen::Isometry3d Tc = loopd::street_pose(town, 0, 0, 0, 75.0, -2.0);
  // Some movable car is in a different state on visit 2.
  int changed = 0;
  for (int id = 0; id < town.num_movables; ++id) changed += town.active_variant(id, 2) != 0 ? 1 : 0;
  CHECK(changed > 0);

  const auto a = loopd::voxel_downsample(loopd::simulate_scan(town, model, Ta, 1, 2, 0), 0.05);
  const auto b = loopd::voxel_downsample(loopd::simulate_scan(town, model, Tb, 2, 2, 2), 0.05);
  const auto c = loopd::voxel_downsample(loopd::simulate_scan(town, model, Tc, 3, 2, 2), 0.05);
  const double same = overlap(b, Tb, a, Ta, 0.3);
  const double far = overlap(c, Tc, a, Ta, 0.3);
  WARN("overlap same place (visits 0/2): " << same << ", 50 m apart: " << far);
  CHECK(same >= 0.70);
  CHECK(far < 0.30);
}

TEST_CASE("parked cars move or vanish between visits", "[sim][visits]") {
  const loopd::Town town = loopd::make_town(1);
  REQUIRE(town.num_movables > 10);
  int moved = 0, gone = 0;
  for (int id = 0; id < town.num_movables; ++id) {
    CHECK(town.active_variant(id, 0) == 0);
    const int v = town.active_variant(id, 5);
    CHECK(v == town.active_variant(id, 5));
    moved += v == 1;
    gone += v == 2;
  }
  CHECK(moved > 0);
  CHECK(gone > 0);
  // A ray at a vanished car's body hits the car on visit 0 and something farther on that visit.
  bool checked = false;
  for (const auto& p : town.primitives) {
    if (p.movable_id < 0 || p.variant != 0 || town.active_variant(p.movable_id, 5) != 2) continue;
    const Eigen::Vector3d target = 0.5 * (p.a + p.b);
    const Eigen::Vector3d origin = target + Eigen::Vector3d(0.0, 0.0, 5.0);
    const Eigen::Vector3d dir = (target - origin).normalized();
    const double r0 = loopd::cast_ray(town, origin, dir, 100.0, 0);
    const double r5 = loopd::cast_ray(town, origin, dir, 100.0, 5);
    CHECK(r0 < 5.0);
    CHECK(r5 > r0 + 0.3);
    checked = true;
    break;
  }
  CHECK(checked);
}

TEST_CASE("scene helpers: other town, corridor", "[sim][scenes]") {
  const loopd::Town a = loopd::make_town(1);
  const loopd::Town b = loopd::make_other_town(1);
  CHECK(a.street_x != b.street_x);
  CHECK(std::abs(static_cast<double>(a.primitives.size()) - static_cast<double>(b.primitives.size())) <
        0.5 * static_cast<double>(a.primitives.size()));  // same pattern: similar amount of structure
  const auto model = loopd::lidar_model_hdl64();
  // Scans at the "same" street position of both towns do not overlap.
  const Eigen::Isometry3d Ta = loopd::street_pose(a, 0, 0, 0, 25.0);
  const Eigen::Isometry3d Tb = loopd::street_pose(b, 0, 0, 0, 25.0);
  // Compare the structure above the ground (the road looks alike everywhere): sensor-frame z > -1.2 m.
  auto structure = [](const loopd::PointCloud& c) {
    loopd::PointCloud out;
    for (const auto& p : c.points)
      if (p.z() > -1.2f) out.points.push_back(p);
    return out;
  };
  const auto sa = structure(loopd::voxel_downsample(loopd::simulate_scan(a, model, Ta, 1, 2), 0.05));
  const auto sb = structure(loopd::voxel_downsample(loopd::simulate_scan(b, model, Tb, 1, 2), 0.05));
  const auto sa2 = structure(loopd::voxel_downsample(loopd::simulate_scan(a, model, Ta, 2, 2), 0.05));
  const double ab = overlap(sb, Eigen::Isometry3d::Identity(), sa, Eigen::Isometry3d::Identity(), 0.3);
  const double aa = overlap(sa2, Eigen::Isometry3d::Identity(), sa, Eigen::Isometry3d::Identity(), 0.3);
  WARN("structure overlap at node (0,0)+25 m: other town " << ab << ", same town (other noise) " << aa);
  // Streets of the same pattern share road width and facade lines, so some facade points coincide by chance; the
  // buildings, gaps, trees and cars differ.
  CHECK(aa > 0.9);
  CHECK(ab < 0.6);
  CHECK(ab < aa - 0.3);

  // Corridor: moving 5 m along it changes (almost) nothing in the sensor frame -> degenerate along x.
  const loopd::Town tunnel = loopd::make_corridor();
  CHECK_FALSE(loopd::CorridorConfig{}.validate());
  const Eigen::Isometry3d T0 = loopd::street_pose(tunnel, 0, 0, 0, 0.0, 0.0);
  const Eigen::Isometry3d T5 = loopd::street_pose(tunnel, 0, 0, 0, 5.0, 0.0);
  CHECK(T5.translation().x() == Approx(5.0));
  CHECK(T0.translation().z() == Approx(1.8));
  const auto c0 = loopd::voxel_downsample(loopd::simulate_scan(tunnel, model, T0, 1, 2), 0.05);
  const auto c5 = loopd::voxel_downsample(loopd::simulate_scan(tunnel, model, T5, 2, 2), 0.05);
  CHECK(c0.size() > 50000);
  const double same_frame = overlap(c5, Eigen::Isometry3d::Identity(), c0, Eigen::Isometry3d::Identity(), 0.3);
  WARN("corridor: overlap of scans 5 m apart without any alignment: " << same_frame);
  CHECK(same_frame > 0.9);
}
