// The junction chambers of make_mine and the only distinctive structure of the mine: corner pillars, equipment,
// niches with parked vehicles, ventilation door frames (all within ~12 m of a chamber).
#include <algorithm>
#include <cmath>
#include <utility>

#include "loopd/sim/mine_build.hpp"

namespace loopd::detail {
namespace {

/// [m] corner features stay this far from the roadway centre lines (plus 0.2 m): a route corner of radius <= 3 m
/// (a quadratic Bezier from 3 m before the node to 3 m after it) never has both coordinates beyond 2.3 m.
constexpr double kPathClear = 2.3;

}  // namespace

double MineBuilder::opening(const MineJunction& jn, int di, int dj) const {
  const MineRoadway* r = l_.roadway(jn.i, jn.j, jn.i + di, jn.j + dj);
  return r ? 0.5 * r->width : 0.0;
}

void MineBuilder::chamber_walls(const MineJunction& jn) {
  const double a = jn.half_size, far = a + kMineRock;
  const int dirs[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  for (const auto& d : dirs) {
    const double hw = opening(jn, d[0], d[1]);
    std::vector<std::pair<double, double>> spans;  // along the side, relative to the centre; the opening left out
    if (hw > 0.0) {
      spans = {{-far, -hw}, {hw, far}};
    } else {
      spans = {{-far, far}};
    }
    for (const auto& [t0, t1] : spans) {
      const double n0 = a + rng_.sign() * rng_.uniform(c_.min_jitter, c_.max_jitter);
      Eigen::Vector3d lo, hi;
      if (d[0] != 0) {
        lo = Eigen::Vector3d(jn.centre.x() + d[0] * n0, jn.centre.y() + t0, -1.0);
        hi = Eigen::Vector3d(jn.centre.x() + d[0] * far, jn.centre.y() + t1, jn.height + kMineRock);
      } else {
        lo = Eigen::Vector3d(jn.centre.x() + t0, jn.centre.y() + d[1] * n0, -1.0);
        hi = Eigen::Vector3d(jn.centre.x() + t1, jn.centre.y() + d[1] * far, jn.height + kMineRock);
      }
      t_.primitives.push_back(mine_box(lo, hi, rock()));
    }
  }
  const Eigen::Vector3d lo(jn.centre.x() - far, jn.centre.y() - far, jn.height);
  const Eigen::Vector3d hi(jn.centre.x() + far, jn.centre.y() + far, jn.height + kMineRock);
  t_.primitives.push_back(mine_box(lo, hi, rock()));
}

void MineBuilder::equipment(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const Eigen::Vector2d& moved_by, bool movable) {
  const double h = rng_.uniform(0.8, 1.8);
  const float refl = static_cast<float>(rng_.uniform(0.4, 0.8));
  const int id = movable ? t_.num_movables++ : -1;
  for (int v = 0; v < (movable ? 2 : 1); ++v) {
    const Eigen::Vector2d o = v == 1 ? moved_by : Eigen::Vector2d::Zero();
    Primitive p = mine_box(Eigen::Vector3d(lo.x() + o.x(), lo.y() + o.y(), 0.0), Eigen::Vector3d(hi.x() + o.x(), hi.y() + o.y(), h), refl);
    p.movable_id = id;
    p.variant = v;
    t_.primitives.push_back(p);
  }
}

void MineBuilder::corner_feature(const MineJunction& jn, int sx, int sy) {
  const double a = jn.half_size;
  // Corner-local coordinates (px, py) >= 0 point into the corner; the roadway along y fills |dx| < its half-width.
  const double ix = std::max(opening(jn, 0, sy), kPathClear) + 0.2, iy = std::max(opening(jn, sx, 0), kPathClear) + 0.2;
  const double ex = a - ix, ey = a - iy;
  if (ex < 0.8 || ey < 0.8) return;
  auto at = [&](double px, double py) { return Eigen::Vector2d(jn.centre.x() + sx * px, jn.centre.y() + sy * py); };
  auto column = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
    t_.primitives.push_back(mine_box(Eigen::Vector3d(p.x(), p.y(), -1.0), Eigen::Vector3d(q.x(), q.y(), jn.height + kMineRock), rock()));
  };
  const double kind = rng_.uniform();
  if (kind < 0.3) return;  // a plain corner
  if (kind < 0.5) {        // rib pillar: the corner filled from a seeded edge out into the rock (another corner shape)
    column(at(ix + rng_.uniform(0.3, ex - 0.3), iy + rng_.uniform(0.3, ey - 0.3)), at(a + kMineRock, a + kMineRock));
  } else if (kind < 0.75) {  // free-standing pillar
    const double s = rng_.uniform(0.5, std::min(0.9, std::min(ex, ey) - 0.3));
    const Eigen::Vector2d c = at(ix + 0.5 * ex, iy + 0.5 * ey);
    column(c - Eigen::Vector2d(0.5 * s, 0.5 * s), c + Eigen::Vector2d(0.5 * s, 0.5 * s));
  } else {  // equipment box
    const double w = rng_.uniform(0.5, std::min(1.2, ex - 0.2)), d = rng_.uniform(0.5, std::min(1.2, ey - 0.2));
    const Eigen::Vector2d moved(sx * std::min(0.5, ex - 0.2 - w), sy * std::min(0.5, ey - 0.2 - d));
    equipment(at(ix + 0.1, iy + 0.1), at(ix + 0.1 + w, iy + 0.1 + d), moved, rng_.chance(c_.movable_fraction));
  }
}

void MineBuilder::vehicle(const RoadFrame& f, const MineNiche& n) {
  const double w = rng_.uniform(1.6, 1.9), len = rng_.uniform(3.6, 4.6), hb = rng_.uniform(1.3, 1.7);
  const double s = n.side;
  const double v_out = s * (f.hw + n.depth - 0.3), v_in = s * (f.hw + n.depth - 0.3 - w);
  const double slack = std::max(0.0, 0.5 * (n.u1 - n.u0 - len) - 0.1);
  const bool movable = rng_.chance(c_.movable_fraction);
  const int id = movable ? t_.num_movables++ : -1;
  const float refl = static_cast<float>(rng_.uniform(0.3, 0.9));
  const double shift = std::clamp(rng_.sign() * rng_.uniform(0.6, 1.5), -slack, slack);
  const bool cab_first = rng_.chance(0.5);
  for (int v = 0; v < (movable ? 2 : 1); ++v) {
    const double uc = 0.5 * (n.u0 + n.u1) + (v == 1 ? shift : 0.0);
    const double c0 = cab_first ? uc - 0.5 * len : uc + 0.5 * len - 1.3;
    Primitive body = local_box(f, uc - 0.5 * len, uc + 0.5 * len, v_in, v_out, 0.3, hb, refl);
    Primitive cab = local_box(f, c0, c0 + 1.3, v_in + 0.1 * s, v_out - 0.1 * s, hb, hb + 0.8, refl * 0.6f);
    body.movable_id = cab.movable_id = id;
    body.variant = cab.variant = v;
    t_.primitives.push_back(body);
    t_.primitives.push_back(cab);
  }
}

void MineBuilder::niche(std::size_t roadway, bool at_start) {
  const RoadFrame f = frame(l_.roadways[roadway]);
  const double dist = rng_.uniform(3.0, 7.0), len = rng_.uniform(6.0, 7.5);
  MineNiche n;
  n.roadway = roadway;
  n.side = rng_.chance(0.5) ? 1 : -1;
  n.depth = rng_.uniform(2.4, 3.0);
  n.u0 = at_start ? f.u0 + dist : f.u1 - dist - len;
  n.u1 = n.u0 + len;
  niches_.push_back(n);
  const double kind = rng_.uniform();
  if (kind < c_.vehicle_fraction) {
    vehicle(f, n);
  } else if (kind < 0.5 * (1.0 + c_.vehicle_fraction)) {  // a static box (pump, transformer) in the niche
    const double s = n.side, l0 = n.u0 + rng_.uniform(0.5, 2.0);
    t_.primitives.push_back(local_box(f, l0, l0 + rng_.uniform(1.5, 3.0), s * (f.hw + n.depth - 0.2), s * (f.hw + n.depth - rng_.uniform(1.2, 2.0)),
                                      0.0, rng_.uniform(1.0, 2.2), static_cast<float>(rng_.uniform(0.4, 0.8))));
  }
}

void MineBuilder::door_frame(std::size_t roadway, bool at_start) {
  const RoadFrame f = frame(l_.roadways[roadway]);
  const double th = rng_.uniform(0.3, 0.5), d = rng_.uniform(1.5, 2.5), post = rng_.uniform(0.35, 0.5);
  const double u = at_start ? f.u0 + d : f.u1 - d - th;
  const float refl = static_cast<float>(rng_.uniform(0.5, 0.8));
  for (double s : {-1.0, 1.0}) t_.primitives.push_back(local_box(f, u, u + th, s * (f.hw - post), s * (f.hw + 1.0), -1.0, f.h + 0.5, refl));
  t_.primitives.push_back(local_box(f, u, u + th, -(f.hw + 1.0), f.hw + 1.0, f.h - rng_.uniform(0.5, 0.8), f.h + 0.5, refl));
}

void MineBuilder::junction(const MineJunction& jn) {
  chamber_walls(jn);
  for (int sx : {-1, 1})
    for (int sy : {-1, 1}) corner_feature(jn, sx, sy);
  std::vector<std::pair<std::size_t, bool>> incident;  // (roadway, whether it starts here)
  for (std::size_t k = 0; k < l_.roadways.size(); ++k) {
    const MineRoadway& r = l_.roadways[k];
    if (r.i0 == jn.i && r.j0 == jn.j) incident.emplace_back(k, true);
    if (r.i1 == jn.i && r.j1 == jn.j) incident.emplace_back(k, false);
  }
  if (incident.empty()) return;
  const std::size_t pick = static_cast<std::size_t>(rng_.next() % incident.size());
  niche(incident[pick].first, incident[pick].second);
  if (incident.size() > 1 && rng_.chance(0.6)) {
    const std::size_t other = (pick + 1 + static_cast<std::size_t>(rng_.next() % (incident.size() - 1))) % incident.size();
    door_frame(incident[other].first, incident[other].second);
  }
}

}  // namespace loopd::detail
