// The simulated mine (make_mine), its route (make_drive with route "mine") and the movers export (changing_movers).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "loopd/sim/drive.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/mine.hpp"
#include "loopd/sim/movers.hpp"

using namespace loopd;

namespace {

bool same_primitives(const Town& a, const Town& b) {
  if (a.primitives.size() != b.primitives.size()) return false;
  for (std::size_t k = 0; k < a.primitives.size(); ++k) {
    const Primitive &p = a.primitives[k], &q = b.primitives[k];
    if (p.a != q.a || p.b != q.b || p.movable_id != q.movable_id || p.variant != q.variant || p.reflectivity != q.reflectivity) return false;
  }
  return true;
}

/// True when planar `p` lies on a roadway or in a junction chamber, at least `margin` inside its walls.
bool on_roadways(const MineLayout& l, const Eigen::Vector2d& p, double margin) {
  for (const MineRoadway& r : l.roadways) {
    const MineJunction &a = *l.junction(r.i0, r.j0), &b = *l.junction(r.i1, r.j1);
    const int ax = r.along_x ? 0 : 1, lat = 1 - ax;
    const bool along = p[ax] >= a.centre[ax] - a.half_size && p[ax] <= b.centre[ax] + b.half_size;
    if (along && std::abs(p[lat] - a.centre[lat]) <= 0.5 * r.width - margin) return true;
  }
  for (const MineJunction& jn : l.junctions)
    if ((p - jn.centre).cwiseAbs().maxCoeff() <= jn.half_size - margin) return true;
  return false;
}

DriveConfig mine_drive(int scans) {
  DriveConfig c;
  c.route = "mine";
  c.sensor = "vlp16";
  c.num_scans = scans;
  return c;
}

}  // namespace

TEST_CASE("make_mine is deterministic for a seed and different for another", "[sim][mine]") {
  const Town a = make_mine(1), b = make_mine(1), c = make_mine(2);
  CHECK(a.name == "mine-1");
  CHECK(a.primitives.size() > 1500);
  CHECK(same_primitives(a, b));
  CHECK_FALSE(same_primitives(a, c));
  CHECK(a.num_movables > 0);
  CHECK(a.num_variants == 3);
  CHECK_FALSE(a.lane_markings);
  CHECK(a.ground_height(100.0, 50.0) == 0.0);
  // Node (i, j) is junction (i, j) of the layout: 4 x 3 = 12 junctions, 60-100 m apart.
  const MineLayout l = make_mine_layout(MineConfig{});
  REQUIRE(l.junctions.size() == 12);
  CHECK(l.roadways.size() == 17);
  for (const MineJunction& jn : l.junctions) {
    REQUIRE(a.has_node(jn.i, jn.j));
    CHECK((a.node(jn.i, jn.j) - jn.centre).norm() == 0.0);
  }
  CHECK_FALSE(a.has_node(4, 0));
  CHECK_FALSE(a.has_node(0, 3));
  for (std::size_t k = 1; k < l.line_x.size(); ++k) CHECK(l.line_x[k] - l.line_x[k - 1] == Approx(80.0).margin(20.0));
  for (const MineRoadway& r : l.roadways) {
    CHECK(r.width == Approx(5.0).margin(1.0));
    CHECK(r.height == Approx(4.5).margin(0.5));
  }
  MineConfig bad;
  bad.min_width = 3.0;
  CHECK(bad.validate());
  CHECK_FALSE(MineConfig{}.validate());
  CHECK(make_mine(bad).primitives.empty());
}

TEST_CASE("mid-roadway rays hit the rough walls at the roadway's half-width and the roof at its height", "[sim][mine]") {
  const Town mine = make_mine(1);
  const MineLayout l = make_mine_layout(MineConfig{});
  for (const MineRoadway& r : l.roadways) {
    const Eigen::Vector2d a = l.junction(r.i0, r.j0)->centre, b = l.junction(r.i1, r.j1)->centre;
    const Eigen::Vector2d axis = (b - a).normalized(), left(-axis.y(), axis.x());
    INFO("roadway (" << r.i0 << "," << r.j0 << ")-(" << r.i1 << "," << r.j1 << ") width " << r.width << " height " << r.height);
    // Between 20 m from either junction: no niche, door frame or chamber.
    for (double s = 20.0; s < (b - a).norm() - 20.0; s += 3.7) {
      const Eigen::Vector2d c = a + s * axis;
      const Eigen::Vector3d o(c.x(), c.y(), 1.8);
      for (double side : {-1.0, 1.0}) {
        const double wall = cast_ray(mine, o, Eigen::Vector3d(side * left.x(), side * left.y(), 0.0), 100.0);
        CHECK(wall == Approx(0.5 * r.width).margin(0.3));
      }
      CHECK(cast_ray(mine, o, Eigen::Vector3d::UnitZ(), 100.0) == Approx(r.height - 1.8).margin(0.3));
      CHECK(cast_ray(mine, o, -Eigen::Vector3d::UnitZ(), 100.0) == Approx(1.8).margin(1e-6));  // the floor
    }
  }
}

TEST_CASE("the mine route is a closed lap of three visits on the roadways, with revisits and no U-turns", "[sim][mine][drive]") {
  const Drive d = make_drive(mine_drive(2600));  // 1.3 km at the mine's 5 m/s
  REQUIRE(d.error.empty());
  CHECK(d.town.name == "mine-1");
  CHECK(d.config.lane_lateral == 0.0);  // the route's defaults (the town's -2 m, 9 m and 10 m/s were left in the config)
  CHECK(d.config.corner_radius == 3.0);
  CHECK(d.config.speed == 5.0);
  CHECK(d.lap_length > 800.0);
  CHECK(d.lap_length < 1300.0);
  CHECK(d.num_visits() >= 3);                                // (and the next lap's first, when the lap is shorter than 1.3 km)
  CHECK((d.path.front().p - d.path.back().p).norm() < 0.2);  // closed
  CHECK(d.count_revisits(1.0, 100) > 100);
  const MineLayout l = make_mine_layout(MineConfig{});
  std::size_t off = 0;
  for (const DrivePathPoint& q : d.path) off += on_roadways(l, q.p, 1.0) ? 0 : 1;
  CHECK(off == 0);
  for (const DriveScan& s : d.scans) CHECK(on_roadways(l, s.T_world_sensor.translation().head<2>(), 1.0));
  // No U-turns: the heading turns by at most ~90 deg over 10 m of path.
  for (std::size_t k = 0; k + 200 < d.path.size(); k += 50) {
    const Eigen::Vector2d u = d.path[k + 20].p - d.path[k].p, v = d.path[k + 200].p - d.path[k + 180].p;
    CHECK(u.normalized().dot(v.normalized()) > -0.1);
  }
  // An explicit lane and corner radius are kept.
  DriveConfig own = mine_drive(10);
  own.corner_radius = 4.0;
  CHECK(make_drive(own).config.corner_radius == 4.0);
  // Another session drives the same mine from elsewhere.
  DriveConfig s2 = mine_drive(300);
  s2.session = 2;
  const Drive d2 = make_drive(s2);
  REQUIRE(d2.error.empty());
  CHECK(same_primitives(d2.town, d.town));
  CHECK(d2.start_offset > 0.0);
}

TEST_CASE("changing_movers lists the objects whose state changes, with boxes around their primitives", "[sim][mine][movers]") {
  for (const std::string route : {"mine", "block"}) {
    DriveConfig c = mine_drive(route == "mine" ? 700 : 500);
    c.route = route;
    const Drive d = make_drive(c);
    REQUIRE(d.error.empty());
    REQUIRE(d.num_visits() >= 2);
    const std::vector<MoverBox> movers = changing_movers(d);
    INFO(route << ": " << movers.size() << " boxes of " << d.town.num_movables << " movables");
    CHECK_FALSE(movers.empty());
    std::set<int> listed;
    for (const MoverBox& m : movers) listed.insert(m.movable_id);
    for (int id = 0; id < d.town.num_movables; ++id) {
      std::set<int> shown;
      for (const DriveScan& s : d.scans) shown.insert(d.town.active_variant(id, s.visit + d.car_visit_offset));
      CHECK((shown.size() >= 2) == (listed.count(id) == 1));
    }
    // Each box says whether the object has left it by the last scan.
    for (const MoverBox& m : movers) CHECK(m.left == (d.town.active_variant(m.movable_id, d.scans.back().visit + d.car_visit_offset) != m.variant));
    CHECK(std::any_of(movers.begin(), movers.end(), [](const MoverBox& m) { return m.left; }));
    for (const Primitive& p : d.town.primitives) {
      if (p.movable_id < 0 || !listed.count(p.movable_id)) continue;
      bool inside = false;
      for (const MoverBox& m : movers) {
        if (m.movable_id != p.movable_id || m.variant != p.variant) continue;
        inside = (p.a.array() >= m.min.array() - 1e-9).all() && (p.b.array() <= m.max.array() + 1e-9).all();
      }
      CHECK(inside);
    }
    for (const MoverBox& m : movers) CHECK(m.variant != 2);
    // The JSON: exactly the documented keys, in order.
    const std::string text = movers_json(movers);
    CHECK(text.rfind("{\"format\":\"loopd-movers\",\"version\":1,\"movers\":[{\"id\":", 0) == 0);
    const nlohmann::json j = nlohmann::json::parse(text);
    REQUIRE(j["movers"].size() == movers.size());
    CHECK(j["movers"][0]["min"].size() == 3);
    CHECK(j["movers"][0]["variant"] == movers[0].variant);
  }
  // Visit 0 only: nothing changes.
  const Drive first = make_drive(mine_drive(200));
  REQUIRE(first.num_visits() == 1);
  CHECK(changing_movers(first).empty());
  CHECK(movers_json({}) == "{\"format\":\"loopd-movers\",\"version\":1,\"movers\":[]}");
}
