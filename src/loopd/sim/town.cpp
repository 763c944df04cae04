#include "loopd/sim/town.hpp"

#include <algorithm>
#include <cmath>
#include "loopd/base/angles.hpp"

namespace loopd {
namespace {

/// Counter-based generator: deterministic on every platform (no std:: distributions, whose output is
/// implementation-defined).
class TownRng {
 public:
  explicit TownRng(std::uint64_t seed) : state_(detail::mix64(seed ^ 0xA0761D6478BD642Full)) {}
  std::uint64_t next() { return detail::mix64(state_ += 0x9E3779B97F4A7C15ull); }
  double uniform() { return detail::hash_uniform(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  bool chance(double p) { return uniform() < p; }

 private:
  std::uint64_t state_;
};

Primitive make_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, float refl) {
  Primitive p;
  p.type = PrimitiveType::kBox;
  p.a = lo.cwiseMin(hi);
  p.b = lo.cwiseMax(hi);
  p.reflectivity = refl;
  return p;
}

Primitive make_cylinder(double cx, double cy, double z0, double z1, double r, float refl) {
  Primitive p;
  p.type = PrimitiveType::kCylinder;
  p.a = Eigen::Vector3d(cx, cy, z0);
  p.b = Eigen::Vector3d(cx, cy, z1);
  p.radius = r;
  p.reflectivity = refl;
  return p;
}

Primitive make_sphere(const Eigen::Vector3d& c, double r, float refl) {
  Primitive p;
  p.type = PrimitiveType::kSphere;
  p.a = c;
  p.b = c;
  p.radius = r;
  p.reflectivity = refl;
  return p;
}

/// Builds the town step by step; `g` is the ground height function of the town.
class TownBuilder {
 public:
  TownBuilder(Town* town, std::uint64_t seed) : t_(*town), rng_(seed) {}

  double ground(double x, double y) const { return t_.ground_height(x, y); }
  double level(double x, double y) const { return ground(x, y) + t_.config.kerb_height; }
  float refl(double lo, double hi) { return static_cast<float>(rng_.uniform(lo, hi)); }

  /// A tree: trunk cylinder + spherical crown.
  void tree(double x, double y, double base) {
    const double trunk_h = rng_.uniform(2.0, 3.5);
    const double crown_r = rng_.uniform(1.8, 3.2);
    t_.primitives.push_back(make_cylinder(x, y, base - 0.5, base + trunk_h, rng_.uniform(0.15, 0.3), refl(0.3, 0.5)));
    t_.primitives.push_back(make_sphere(Eigen::Vector3d(x, y, base + trunk_h + 0.7 * crown_r), crown_r, refl(0.35, 0.6)));
    t_.primitives.back().vegetation = true;
  }

  /// A street light / sign pole.
  void pole(double x, double y, double base) {
    const double h = rng_.uniform(4.5, 8.0);
    t_.primitives.push_back(make_cylinder(x, y, base - 0.5, base + h, rng_.uniform(0.08, 0.15), refl(0.4, 0.8)));
  }

  /// A car (body + cabin) centred at (x, y) with its long axis along x (along_x) or y.
  void car(double x, double y, bool along_x, double len, double wid, double height, float refl, int movable_id, int variant) {
    const double g = ground(x, y);
    const double hl = 0.5 * len, hw = 0.5 * wid;
    const Eigen::Vector3d half_body = along_x ? Eigen::Vector3d(hl, hw, 0) : Eigen::Vector3d(hw, hl, 0);
    Primitive body = make_box(Eigen::Vector3d(x, y, g + 0.25) - half_body, Eigen::Vector3d(x, y, g + 1.0) + half_body, refl);
    const double cl = 0.3 * len, cw = hw - 0.08;
    const double shift = 0.05 * len;  // cabin slightly behind the centre
    const Eigen::Vector3d half_cabin = along_x ? Eigen::Vector3d(cl, cw, 0) : Eigen::Vector3d(cw, cl, 0);
    const Eigen::Vector3d cabin_c = along_x ? Eigen::Vector3d(x - shift, y, 0) : Eigen::Vector3d(x, y - shift, 0);
    Primitive cabin =
        make_box(cabin_c + Eigen::Vector3d(0, 0, g + 1.0) - half_cabin, cabin_c + Eigen::Vector3d(0, 0, g + height) + half_cabin, refl * 0.6f);
    body.movable_id = cabin.movable_id = movable_id;
    body.variant = cabin.variant = variant;
    t_.primitives.push_back(body);
    t_.primitives.push_back(cabin);
  }

  /// A parked car; movable ones get variant 1 (moved along the kerb) and variant 2 (gone: no primitives).
  void parked_car(double x, double y, bool along_x, double slack_lo, double slack_hi) {
    const double len = rng_.uniform(3.9, 4.9), wid = rng_.uniform(1.7, 1.9), h = rng_.uniform(1.4, 1.7);
    const float r = refl(0.1, 0.9);
    const bool movable = rng_.chance(t_.config.movable_fraction);
    const int id = movable ? t_.num_movables++ : -1;
    car(x, y, along_x, len, wid, h, r, id, 0);
    if (movable) {
      // Moved by 2.5..5 m along the kerb (within the slot's slack), maybe a different car.
      double d = rng_.uniform(2.5, 5.0) * (rng_.chance(0.5) ? 1.0 : -1.0);
      d = std::clamp(d, slack_lo, slack_hi);
      car(along_x ? x + d : x, along_x ? y : y + d, along_x, rng_.uniform(3.9, 4.9), wid, rng_.uniform(1.4, 1.7), refl(0.1, 0.9), id, 1);
    }
  }

  /// A building segment of a facade: a box behind the facade line, with a few balconies.
  /// `side`: 0 = facade faces -y (south edge), 1 = +x (east), 2 = +y (north), 3 = -x (west).
  void building(int side, double u0, double u1, double facade, double setback, double depth, double height) {
    const double s = (side == 0 || side == 3) ? 1.0 : -1.0;  // direction from the facade into the block
    const double f = facade + s * setback;
    const double g_lo = -2.0;
    Eigen::Vector3d lo, hi;
    double cx, cy;
    if (side == 0 || side == 2) {
      cx = 0.5 * (u0 + u1);
      cy = f + s * 0.5 * depth;
    } else {
      cx = f + s * 0.5 * depth;
      cy = 0.5 * (u0 + u1);
    }
    const double base = level(cx, cy);
    if (side == 0 || side == 2) {
      lo = Eigen::Vector3d(u0, std::min(f, f + s * depth), base + g_lo);
      hi = Eigen::Vector3d(u1, std::max(f, f + s * depth), base + height);
    } else {
      lo = Eigen::Vector3d(std::min(f, f + s * depth), u0, base + g_lo);
      hi = Eigen::Vector3d(std::max(f, f + s * depth), u1, base + height);
    }
    t_.primitives.push_back(make_box(lo, hi, refl(0.25, 0.7)));
    t_.primitives.back().windows = height > 5.0 && rng_.chance(0.8);
    // Balconies: 1 m deep slabs sticking out of the facade on upper floors.
    if (height > 7.0 && rng_.chance(0.35)) {
      const int n = 1 + static_cast<int>(rng_.uniform() * 3.0);
      for (int k = 0; k < n; ++k) {
        const double w = rng_.uniform(2.5, 4.0);
        if (u1 - u0 < w + 1.0) break;
        const double c = rng_.uniform(u0 + 0.5 * w + 0.5, u1 - 0.5 * w - 0.5);
        const double z = base + 3.0 * std::floor(rng_.uniform(1.0, std::max(1.0, height / 3.0 - 1.0)));
        const double out0 = f, out1 = f - s * 1.0;
        Eigen::Vector3d blo, bhi;
        if (side == 0 || side == 2) {
          blo = Eigen::Vector3d(c - 0.5 * w, std::min(out0, out1), z);
          bhi = Eigen::Vector3d(c + 0.5 * w, std::max(out0, out1), z + 1.0);
        } else {
          blo = Eigen::Vector3d(std::min(out0, out1), c - 0.5 * w, z);
          bhi = Eigen::Vector3d(std::max(out0, out1), c + 0.5 * w, z + 1.0);
        }
        t_.primitives.push_back(make_box(blo, bhi, refl(0.3, 0.7)));
      }
    }
  }

  /// Facade segments along one side of a block interior, from u_lo to u_hi.
  void facade_row(int side, double u_lo, double u_hi, double facade, double max_depth) {
    double u = u_lo;
    while (u < u_hi - 3.0) {
      if (rng_.chance(0.12)) {  // alley / gap between buildings
        u += rng_.uniform(3.0, 6.0);
        continue;
      }
      double w = rng_.uniform(6.0, 16.0);
      if (u_hi - (u + w) < 5.0) w = u_hi - u;
      const double setback = rng_.chance(0.5) ? rng_.uniform(0.5, 3.0) : 0.0;  // recess of the facade
      const double depth = std::min(max_depth, rng_.uniform(10.0, 18.0));
      const double height = rng_.chance(0.2) ? rng_.uniform(3.5, 6.0) : rng_.uniform(6.0, 22.0);
      building(side, u, u + w, facade, setback, depth, height);
      u += w;
    }
  }

  /// A wall segment from (x0, y0) to (x1, y1) (axis-aligned), with thickness and height above the block level.
  void wall(double x0, double y0, double x1, double y1, double thick, double height) {
    const double base = level(0.5 * (x0 + x1), 0.5 * (y0 + y1));
    const double ht = 0.5 * thick;
    Eigen::Vector3d lo(std::min(x0, x1) - ht, std::min(y0, y1) - ht, base - 1.0);
    Eigen::Vector3d hi(std::max(x0, x1) + ht, std::max(y0, y1) + ht, base + height);
    t_.primitives.push_back(make_box(lo, hi, refl(0.2, 0.6)));
  }

  /// Walls around a rectangle with one gate per side.
  void boundary_walls(double x0, double y0, double x1, double y1, double height) {
    const double gate = 4.0;
    const double gx = rng_.uniform(x0 + 3.0, std::max(x0 + 3.0, x1 - 3.0 - gate));
    const double gy = rng_.uniform(y0 + 3.0, std::max(y0 + 3.0, y1 - 3.0 - gate));
    for (double y : {y0, y1}) {
      wall(x0, y, gx, y, 0.3, height);
      wall(gx + gate, y, x1, y, 0.3, height);
    }
    for (double x : {x0, x1}) {
      wall(x, y0, x, gy, 0.3, height);
      wall(x, gy + gate, x, y1, 0.3, height);
    }
  }

  void block(double kx0, double ky0, double kx1, double ky1) {
    const auto& c = t_.config;
    // Raised block (sidewalk + lot) with kerb faces on its sides.
    Primitive slab;
    slab.type = PrimitiveType::kSlab;
    slab.a = Eigen::Vector3d(kx0, ky0, c.kerb_height);
    slab.b = Eigen::Vector3d(kx1, ky1, 0.0);
    slab.reflectivity = 0.25f;
    t_.primitives.push_back(slab);

    const double sw = c.sidewalk_width;
    const double ix0 = kx0 + sw, iy0 = ky0 + sw, ix1 = kx1 - sw, iy1 = ky1 - sw;
    const double kind = rng_.uniform();
    if (kind < c.park_fraction) {
      boundary_walls(ix0 + 0.5, iy0 + 0.5, ix1 - 0.5, iy1 - 0.5, rng_.uniform(1.2, 2.5));
      const double spacing = rng_.uniform(8.0, 12.0);
      for (double x = ix0 + 4.0; x < ix1 - 3.0; x += spacing) {
        for (double y = iy0 + 4.0; y < iy1 - 3.0; y += spacing) {
          if (rng_.chance(0.7)) {
            const double tx = x + rng_.uniform(-2.0, 2.0), ty = y + rng_.uniform(-2.0, 2.0);
            tree(tx, ty, level(tx, ty));
          }
        }
      }
    } else if (kind < c.park_fraction + c.lot_fraction) {
      boundary_walls(ix0 + 0.5, iy0 + 0.5, ix1 - 0.5, iy1 - 0.5, rng_.uniform(0.7, 1.1));
      for (double y = iy0 + 5.0; y < iy1 - 5.0; y += 7.0) {
        for (double x = ix0 + 4.0; x < ix1 - 4.0; x += 2.7) {
          if (rng_.chance(0.5)) car(x, y, false, rng_.uniform(3.9, 4.9), rng_.uniform(1.7, 1.9), rng_.uniform(1.4, 1.7), refl(0.1, 0.9), -1, 0);
        }
      }
      for (int k = 0; k < 3; ++k) {
        const double px = rng_.uniform(ix0 + 2, ix1 - 2), py = rng_.uniform(iy0 + 2, iy1 - 2);
        pole(px, py, level(px, py));
      }
    } else {
      const double max_depth = 0.5 * std::min(ix1 - ix0, iy1 - iy0);
      facade_row(0, ix0, ix1, iy0, max_depth);
      facade_row(2, ix0, ix1, iy1, max_depth);
      facade_row(3, iy0, iy1, ix0, max_depth);
      facade_row(1, iy0, iy1, ix1, max_depth);
    }

    // Sidewalk furniture and kerb-side parking along each of the four sides.
    for (int side = 0; side < 4; ++side) {
      const bool along_x = (side == 0 || side == 2);
      const double u_lo = along_x ? kx0 : ky0, u_hi = along_x ? kx1 : ky1;
      const double kerb = side == 0 ? ky0 : side == 1 ? kx1 : side == 2 ? ky1 : kx0;
      const double out = (side == 0 || side == 3) ? -1.0 : 1.0;  // direction from the block to the road
      auto at = [&](double u, double off) {                      // point at u along the side, `off` metres from the kerb (+ = into road)
        return along_x ? Eigen::Vector2d(u, kerb + out * off) : Eigen::Vector2d(kerb + out * off, u);
      };
      // Poles 0.6 m behind the kerb.
      for (double u = u_lo + rng_.uniform(2.0, 10.0); u < u_hi - 2.0; u += rng_.uniform(20.0, 35.0)) {
        const Eigen::Vector2d p = at(u, -0.6);
        pole(p.x(), p.y(), level(p.x(), p.y()));
      }
      // Street trees on some sides.
      if (rng_.chance(0.5)) {
        for (double u = u_lo + rng_.uniform(4.0, 8.0); u < u_hi - 4.0; u += rng_.uniform(8.0, 14.0)) {
          const Eigen::Vector2d p = at(u, -1.4);
          tree(p.x(), p.y(), level(p.x(), p.y()));
        }
      }
      // Parking lane: cars 1 m into the road, slots of 6.5 m, not within 6 m of the corners.
      const double slot = 6.5;
      for (double u = u_lo + 6.0 + 0.5 * slot; u < u_hi - 6.0 - 0.5 * slot; u += slot) {
        if (!rng_.chance(t_.config.car_occupancy)) {
          rng_.next();  // keep the stream aligned whether or not a car is placed
          continue;
        }
        const Eigen::Vector2d p = at(u + rng_.uniform(-0.5, 0.5), 1.05);
        parked_car(p.x(), p.y(), along_x, (u_lo + 6.0 + 2.5) - u, (u_hi - 6.0 - 2.5) - u);
      }
    }
  }

 private:
  Town& t_;
  TownRng rng_;
};

/// Rows of bushes (spheres sunk into the ground) on the inner edge of a share of the sidewalks, from their own random
/// stream: they come after every other primitive, so that the rest of the town is the same with or without them.
void add_bushes(Town* town) {
  const TownConfig& c = town->config;
  TownRng rng(detail::hash_combine(c.seed, 0xB05Eull));
  const double hr = 0.5 * c.road_width;
  auto bush = [&](double x, double y, double radius) {
    Primitive p = make_sphere(Eigen::Vector3d(x, y, town->ground_height(x, y) + c.kerb_height + 0.4 * radius), radius,
                              static_cast<float>(rng.uniform(0.3, 0.5)));
    p.vegetation = p.bush = true;
    town->primitives.push_back(p);
  };
  for (int bj = 0; bj < c.blocks_y; ++bj) {
    for (int bi = 0; bi < c.blocks_x; ++bi) {
      const double kx0 = town->street_x[static_cast<std::size_t>(bi)] + hr, kx1 = town->street_x[static_cast<std::size_t>(bi + 1)] - hr;
      const double ky0 = town->street_y[static_cast<std::size_t>(bj)] + hr, ky1 = town->street_y[static_cast<std::size_t>(bj + 1)] - hr;
      for (int side = 0; side < 4; ++side) {
        if (!rng.chance(c.bush_fraction)) continue;
        const bool along_x = side == 0 || side == 2;
        const double kerb = side == 0 ? ky0 : side == 1 ? kx1 : side == 2 ? ky1 : kx0;
        const double into = (side == 0 || side == 3) ? 1.0 : -1.0;  // from the kerb into the block
        const double lo = (along_x ? kx0 : ky0) + 5.0, hi = (along_x ? kx1 : ky1) - 5.0;
        // One stretch of 10-30 m of the side, bushes 1.2-2.5 m apart, touching the sidewalk's inner edge.
        const double len = rng.uniform(10.0, 30.0);
        const double u0 = rng.uniform(lo, std::max(lo, hi - len));
        for (double u = u0; u < std::min(hi, u0 + len); u += rng.uniform(1.2, 2.5)) {
          const double radius = rng.uniform(0.5, 0.9);
          const double v = kerb + into * (c.sidewalk_width - radius);
          bush(along_x ? u : v, along_x ? v : u, radius);
        }
      }
    }
  }
}

/// Street line positions: `n` lines, line `origin` at 0, spacing uniform in [lo, hi].
std::vector<double> street_lines(TownRng* rng, int n, int origin, double lo, double hi) {
  std::vector<double> v(static_cast<std::size_t>(n), 0.0);
  for (int k = origin + 1; k < n; ++k) v[static_cast<std::size_t>(k)] = v[static_cast<std::size_t>(k - 1)] + rng->uniform(lo, hi);
  for (int k = origin - 1; k >= 0; --k) v[static_cast<std::size_t>(k)] = v[static_cast<std::size_t>(k + 1)] - rng->uniform(lo, hi);
  return v;
}

}  // namespace

std::optional<std::string> TownConfig::validate() const {
  if (blocks_x < 4 || blocks_y < 4) return std::string("blocks_x and blocks_y must be >= 4");
  if (!(min_block > road_width + 2.0 * sidewalk_width + 10.0)) return std::string("min_block too small for road and sidewalks");
  if (!(max_block >= min_block)) return std::string("max_block must be >= min_block");
  if (!(road_width > 4.0) || !(sidewalk_width > 0.5)) return std::string("road_width > 4 and sidewalk_width > 0.5 required");
  if (!(kerb_height >= 0.0 && kerb_height < 1.0)) return std::string("kerb_height must be in [0, 1)");
  if (std::abs(slope_x) > 0.1 || std::abs(slope_y) > 0.1) return std::string("slopes must be gentle (|slope| <= 0.1)");
  if (park_fraction < 0 || lot_fraction < 0 || park_fraction + lot_fraction > 1) return std::string("bad block fractions");
  if (car_occupancy < 0 || car_occupancy > 1 || movable_fraction < 0 || movable_fraction > 1) return std::string("probabilities must be in [0, 1]");
  if (!(cell_size >= 0.5)) return std::string("cell_size must be >= 0.5 m");
  if (!(bush_fraction >= 0 && bush_fraction <= 1)) return std::string("bush_fraction must be in [0, 1]");
  return std::nullopt;
}

Eigen::Vector2d Town::node(int i, int j) const {
  const int a = std::clamp(i + street_origin_i, 0, std::max(0, static_cast<int>(street_x.size()) - 1));
  const int b = std::clamp(j + street_origin_j, 0, std::max(0, static_cast<int>(street_y.size()) - 1));
  if (street_x.empty() || street_y.empty()) return Eigen::Vector2d::Zero();
  return Eigen::Vector2d(street_x[static_cast<std::size_t>(a)], street_y[static_cast<std::size_t>(b)]);
}

bool Town::has_node(int i, int j) const {
  const int a = i + street_origin_i, b = j + street_origin_j;
  return a >= 0 && b >= 0 && a < static_cast<int>(street_x.size()) && b < static_cast<int>(street_y.size());
}

int Town::active_variant(int movable_id, int visit) const {
  if (movable_id < 0 || visit <= 0) return 0;
  const std::uint64_t h =
      detail::hash_combine(detail::hash_combine(config.seed, static_cast<std::uint64_t>(movable_id)), static_cast<std::uint64_t>(visit));
  return static_cast<int>(h % static_cast<std::uint64_t>(num_variants));
}

void Town::build_index() {
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  max_z = -1e300;
  std::vector<Eigen::Vector4d> fp(primitives.size());  // footprint (xmin, ymin, xmax, ymax)
  for (std::size_t k = 0; k < primitives.size(); ++k) {
    const Primitive& p = primitives[k];
    Eigen::Vector4d f;
    double top;
    switch (p.type) {
      case PrimitiveType::kCylinder:
        f = Eigen::Vector4d(p.a.x() - p.radius, p.a.y() - p.radius, p.a.x() + p.radius, p.a.y() + p.radius);
        top = p.b.z();
        break;
      case PrimitiveType::kSphere:
        f = Eigen::Vector4d(p.a.x() - p.radius, p.a.y() - p.radius, p.a.x() + p.radius, p.a.y() + p.radius);
        top = p.a.z() + p.radius;
        break;
      case PrimitiveType::kSlab: {
        f = Eigen::Vector4d(p.a.x(), p.a.y(), p.b.x(), p.b.y());
        double hmax = -1e300;
        for (double x : {p.a.x(), p.b.x()})
          for (double y : {p.a.y(), p.b.y()}) hmax = std::max(hmax, ground_height(x, y) + p.a.z());
        top = hmax;
        break;
      }
      case PrimitiveType::kBox:
      default:
        f = Eigen::Vector4d(p.a.x(), p.a.y(), p.b.x(), p.b.y());
        top = p.b.z();
        break;
    }
    fp[k] = f;
    x0 = std::min(x0, f[0]);
    y0 = std::min(y0, f[1]);
    x1 = std::max(x1, f[2]);
    y1 = std::max(y1, f[3]);
    max_z = std::max(max_z, top);
  }
  if (primitives.empty()) {
    x0 = y0 = -1.0;
    x1 = y1 = 1.0;
    max_z = 0.0;
  }
  cell_size = config.cell_size;
  grid_x0 = x0 - 1.0;
  grid_y0 = y0 - 1.0;
  grid_nx = std::max(1, static_cast<int>(std::ceil((x1 + 1.0 - grid_x0) / cell_size)));
  grid_ny = std::max(1, static_cast<int>(std::ceil((y1 + 1.0 - grid_y0) / cell_size)));
  const std::size_t ncell = static_cast<std::size_t>(grid_nx) * static_cast<std::size_t>(grid_ny);
  std::vector<std::uint32_t> count(ncell + 1, 0);
  auto range = [&](const Eigen::Vector4d& f, int* cx0, int* cy0, int* cx1, int* cy1) {
    *cx0 = std::clamp(static_cast<int>(std::floor((f[0] - grid_x0) / cell_size)), 0, grid_nx - 1);
    *cy0 = std::clamp(static_cast<int>(std::floor((f[1] - grid_y0) / cell_size)), 0, grid_ny - 1);
    *cx1 = std::clamp(static_cast<int>(std::floor((f[2] - grid_x0) / cell_size)), 0, grid_nx - 1);
    *cy1 = std::clamp(static_cast<int>(std::floor((f[3] - grid_y0) / cell_size)), 0, grid_ny - 1);
  };
  for (std::size_t k = 0; k < primitives.size(); ++k) {
    int a, b, c, d;
    range(fp[k], &a, &b, &c, &d);
    for (int cy = b; cy <= d; ++cy)
      for (int cx = a; cx <= c; ++cx) ++count[static_cast<std::size_t>(cy) * static_cast<std::size_t>(grid_nx) + static_cast<std::size_t>(cx) + 1];
  }
  for (std::size_t c = 1; c <= ncell; ++c) count[c] += count[c - 1];
  cell_start = count;
  cell_items.assign(cell_start[ncell], 0);
  std::vector<std::uint32_t> fill(cell_start.begin(), cell_start.end() - 1);
  for (std::size_t k = 0; k < primitives.size(); ++k) {
    int a, b, c, d;
    range(fp[k], &a, &b, &c, &d);
    for (int cy = b; cy <= d; ++cy)
      for (int cx = a; cx <= c; ++cx) {
        const std::size_t cell = static_cast<std::size_t>(cy) * static_cast<std::size_t>(grid_nx) + static_cast<std::size_t>(cx);
        cell_items[fill[cell]++] = static_cast<std::uint32_t>(k);
      }
  }
}

Town make_town(const TownConfig& config) {
  Town town;
  town.name = "town-" + std::to_string(config.seed);
  town.config = config;
  TownRng rng(detail::hash_combine(config.seed, 0x7E57ull));
  town.ground_z0 = 0.0;
  town.ground_gx = config.slope_x;
  town.ground_gy = config.slope_y;
  town.street_origin_i = 3;
  town.street_origin_j = 3;
  town.street_x = street_lines(&rng, config.blocks_x + 1, 3, config.min_block, config.max_block);
  town.street_y = street_lines(&rng, config.blocks_y + 1, 3, config.min_block, config.max_block);
  TownBuilder builder(&town, detail::hash_combine(config.seed, 0xB10Cull));
  const double hr = 0.5 * config.road_width;
  for (int bj = 0; bj < config.blocks_y; ++bj) {
    for (int bi = 0; bi < config.blocks_x; ++bi) {
      builder.block(town.street_x[static_cast<std::size_t>(bi)] + hr, town.street_y[static_cast<std::size_t>(bj)] + hr,
                    town.street_x[static_cast<std::size_t>(bi + 1)] - hr, town.street_y[static_cast<std::size_t>(bj + 1)] - hr);
    }
  }
  add_bushes(&town);
  town.build_index();
  return town;
}

Town make_town(std::uint64_t seed) {
  TownConfig c;
  c.seed = seed;
  return make_town(c);
}

Town make_other_town(std::uint64_t seed) {
  TownConfig c;
  // A different stream of the same generator: same statistics, unrelated block sizes and contents.
  c.seed = detail::mix64(seed ^ 0x0DDBA11C0FFEEull);
  Town t = make_town(c);
  t.name = "other-town-" + std::to_string(seed);
  return t;
}

std::optional<std::string> CorridorConfig::validate() const {
  if (!(length > 10.0) || !(width > 2.0) || !(height > 2.5)) return std::string("corridor needs length > 10, width > 2, height > 2.5 m");
  return std::nullopt;
}

Town make_corridor(const CorridorConfig& config) {
  Town town;
  town.name = "corridor";
  town.config.seed = 0;
  town.config.cell_size = 4.0;
  town.lane_markings = false;
  const double hl = 0.5 * config.length, hw = 0.5 * config.width;
  const float r = 0.4f;
  town.primitives.push_back(make_box(Eigen::Vector3d(-hl, hw, -1.0), Eigen::Vector3d(hl, hw + 0.5, config.height + 0.5), r));
  town.primitives.push_back(make_box(Eigen::Vector3d(-hl, -hw - 0.5, -1.0), Eigen::Vector3d(hl, -hw, config.height + 0.5), r));
  if (config.ceiling) {
    town.primitives.push_back(make_box(Eigen::Vector3d(-hl, -hw - 0.5, config.height), Eigen::Vector3d(hl, hw + 0.5, config.height + 0.5), r));
  }
  town.build_index();
  return town;
}

Eigen::Isometry3d ground_pose(const Town& town, double x, double y, double yaw, double sensor_height) {
  const Eigen::Vector3d n = Eigen::Vector3d(-town.ground_gx, -town.ground_gy, 1.0).normalized();
  Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), town.ground_gx * std::cos(yaw) + town.ground_gy * std::sin(yaw));
  fwd = (fwd - fwd.dot(n) * n).normalized();
  Eigen::Matrix3d R;
  R.col(0) = fwd;
  R.col(2) = n;
  R.col(1) = n.cross(fwd);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(x, y, town.ground_height(x, y)) + sensor_height * n;
  return T;
}

Eigen::Isometry3d street_pose(const Town& town, int i, int j, int direction, double along, double lateral, double sensor_height) {
  if (town.street_x.empty() || town.street_y.empty()) return ground_pose(town, along, lateral, 0.0, sensor_height);
  const Eigen::Vector2d p0 = town.node(i, j);
  const int d = ((direction % 4) + 4) % 4;
  const double yaw = 0.5 * kPi * d;
  const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw));
  const Eigen::Vector2d left(-fwd.y(), fwd.x());
  const Eigen::Vector2d p = p0 + along * fwd + lateral * left;
  return ground_pose(town, p.x(), p.y(), yaw, sensor_height);
}

}  // namespace loopd
