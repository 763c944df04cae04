#include "loopd/sim/mine.hpp"

#include <algorithm>
#include <cmath>

#include "loopd/sim/mine_build.hpp"

namespace loopd {

using detail::kMineRock;
using detail::MineRng;

std::optional<std::string> MineConfig::validate() const {
  if (cells_x < 1 || cells_y < 1 || cells_x > 20 || cells_y > 20) return std::string("cells_x and cells_y must be in [1, 20]");
  if (!(min_width >= 4.0) || !(max_width >= min_width) || !(max_width <= 12.0)) return std::string("need 4 <= min_width <= max_width <= 12 m");
  if (!(min_height >= 2.5) || !(max_height >= min_height) || !(max_height <= 12.0))
    return std::string("need 2.5 <= min_height <= max_height <= 12 m");
  if (!(min_chamber_margin >= 1.0) || !(max_chamber_margin >= min_chamber_margin) || !(max_chamber_margin <= 10.0))
    return std::string("need 1 <= min_chamber_margin <= max_chamber_margin <= 10 m");
  // Every roadway keeps room for its rough walls and the features within ~12 m of each chamber.
  if (!(min_spacing >= max_width + 2.0 * max_chamber_margin + 30.0) || !(max_spacing >= min_spacing))
    return std::string("min_spacing must be >= max_width + 2 max_chamber_margin + 30 m and <= max_spacing");
  if (!(min_piece >= 0.5) || !(max_piece >= min_piece)) return std::string("need 0.5 <= min_piece <= max_piece");
  if (!(min_jitter >= 0.0) || !(max_jitter >= min_jitter) || !(max_jitter <= 0.5)) return std::string("need 0 <= min_jitter <= max_jitter <= 0.5 m");
  if (!(vehicle_fraction >= 0 && vehicle_fraction <= 1) || !(movable_fraction >= 0 && movable_fraction <= 1))
    return std::string("vehicle_fraction and movable_fraction must be in [0, 1]");
  if (!(cell_size >= 0.5)) return std::string("cell_size must be >= 0.5 m");
  return std::nullopt;
}

const MineRoadway* MineLayout::roadway(int ia, int ja, int ib, int jb) const {
  for (const MineRoadway& r : roadways) {
    if ((r.i0 == ia && r.j0 == ja && r.i1 == ib && r.j1 == jb) || (r.i0 == ib && r.j0 == jb && r.i1 == ia && r.j1 == ja)) return &r;
  }
  return nullptr;
}

const MineJunction* MineLayout::junction(int i, int j) const {
  const int nx = static_cast<int>(line_x.size()), ny = static_cast<int>(line_y.size());
  if (i < 0 || j < 0 || i >= nx || j >= ny) return nullptr;
  return &junctions[static_cast<std::size_t>(j * nx + i)];
}

MineLayout make_mine_layout(const MineConfig& c) {
  MineLayout l;
  MineRng rng(detail::hash_combine(c.seed, 0x1A70Dull));
  auto lines = [&](int cells) {
    std::vector<double> v(static_cast<std::size_t>(cells + 1), 0.0);
    for (std::size_t k = 1; k < v.size(); ++k) v[k] = v[k - 1] + rng.uniform(c.min_spacing, c.max_spacing);
    return v;
  };
  l.line_x = lines(c.cells_x);
  l.line_y = lines(c.cells_y);
  auto add = [&](int i0, int j0, int i1, int j1) {
    MineRoadway r;
    r.i0 = i0, r.j0 = j0, r.i1 = i1, r.j1 = j1;
    r.along_x = j0 == j1;
    r.width = rng.uniform(c.min_width, c.max_width);
    r.height = rng.uniform(c.min_height, c.max_height);
    l.roadways.push_back(r);
  };
  for (int j = 0; j <= c.cells_y; ++j)
    for (int i = 0; i < c.cells_x; ++i) add(i, j, i + 1, j);
  for (int j = 0; j < c.cells_y; ++j)
    for (int i = 0; i <= c.cells_x; ++i) add(i, j, i, j + 1);
  for (int j = 0; j <= c.cells_y; ++j) {
    for (int i = 0; i <= c.cells_x; ++i) {
      MineJunction jn;
      jn.i = i, jn.j = j;
      jn.centre = Eigen::Vector2d(l.line_x[static_cast<std::size_t>(i)], l.line_y[static_cast<std::size_t>(j)]);
      double widest = 0.0, highest = 0.0;
      for (const MineRoadway& r : l.roadways) {
        if ((r.i0 == i && r.j0 == j) || (r.i1 == i && r.j1 == j)) widest = std::max(widest, r.width), highest = std::max(highest, r.height);
      }
      jn.half_size = 0.5 * widest + rng.uniform(c.min_chamber_margin, c.max_chamber_margin);
      jn.height = highest + rng.uniform(0.2, 0.8);  // chambers are blasted higher than their roadways
      l.junctions.push_back(jn);
    }
  }
  return l;
}

namespace detail {

Primitive mine_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b, float reflectivity) {
  Primitive p;
  p.type = PrimitiveType::kBox;
  p.a = a.cwiseMin(b);
  p.b = a.cwiseMax(b);
  p.reflectivity = reflectivity;
  return p;
}

MineBuilder::MineBuilder(Town* town, const MineLayout& layout, const MineConfig& config)
    : t_(*town), l_(layout), c_(config), rng_(hash_combine(config.seed, 0xB111Dull)) {}

RoadFrame MineBuilder::frame(const MineRoadway& r) const {
  const MineJunction& a = *l_.junction(r.i0, r.j0);
  const MineJunction& b = *l_.junction(r.i1, r.j1);
  RoadFrame f;
  f.along_x = r.along_x;
  f.vc = r.along_x ? a.centre.y() : a.centre.x();
  f.u0 = (r.along_x ? a.centre.x() : a.centre.y()) + a.half_size;
  f.u1 = (r.along_x ? b.centre.x() : b.centre.y()) - b.half_size;
  f.hw = 0.5 * r.width;
  f.h = r.height;
  return f;
}

Primitive MineBuilder::local_box(const RoadFrame& f, double u0, double u1, double v0, double v1, double z0, double z1, float refl) const {
  if (f.along_x) return mine_box(Eigen::Vector3d(u0, f.vc + v0, z0), Eigen::Vector3d(u1, f.vc + v1, z1), refl);
  return mine_box(Eigen::Vector3d(f.vc + v0, u0, z0), Eigen::Vector3d(f.vc + v1, u1, z1), refl);
}

void MineBuilder::wall_pieces(const RoadFrame& f, int side, double u0, double u1) {
  const double s = side;
  for (double u = u0; u < u1 - 1e-9;) {
    double e = u + rng_.uniform(c_.min_piece, c_.max_piece);
    if (u1 - e < c_.min_piece) e = u1;  // no sliver at the end: the last piece takes the rest
    const double face = f.hw + rng_.sign() * rng_.uniform(c_.min_jitter, c_.max_jitter);
    t_.primitives.push_back(local_box(f, u, e, s * face, s * (f.hw + kMineRock), -1.0, f.h + kMineRock, rock()));
    u = e;
  }
}

void MineBuilder::roof_pieces(const RoadFrame& f) {
  for (double u = f.u0; u < f.u1 - 1e-9;) {
    double e = u + rng_.uniform(c_.min_piece, c_.max_piece);
    if (f.u1 - e < c_.min_piece) e = f.u1;
    const double z = f.h + rng_.sign() * rng_.uniform(c_.min_jitter, c_.max_jitter);
    t_.primitives.push_back(local_box(f, u, e, -(f.hw + kMineRock), f.hw + kMineRock, z, f.h + kMineRock, rock()));
    u = e;
  }
}

void MineBuilder::roadway(std::size_t k) {
  const RoadFrame f = frame(l_.roadways[k]);
  for (int side : {-1, 1}) {
    std::vector<MineNiche> here;
    for (const MineNiche& n : niches_)
      if (n.roadway == k && n.side == side) here.push_back(n);
    std::sort(here.begin(), here.end(), [](const MineNiche& a, const MineNiche& b) { return a.u0 < b.u0; });
    double u = f.u0;
    for (const MineNiche& n : here) {
      wall_pieces(f, side, u, n.u0);
      t_.primitives.push_back(local_box(f, n.u0, n.u1, side * (f.hw + n.depth), side * (f.hw + kMineRock), -1.0, f.h + kMineRock, rock()));
      u = n.u1;
    }
    wall_pieces(f, side, u, f.u1);
  }
  roof_pieces(f);
}

}  // namespace detail

Town make_mine(const MineConfig& config) {
  Town town;
  town.config.seed = config.seed;  // Town::active_variant hashes it
  town.config.cell_size = config.cell_size;
  town.lane_markings = false;
  town.num_variants = 3;
  if (config.validate()) {
    town.name = "mine-invalid";
    town.build_index();
    return town;
  }
  town.name = "mine-" + std::to_string(config.seed);
  const MineLayout layout = make_mine_layout(config);
  town.street_x = layout.line_x;
  town.street_y = layout.line_y;
  detail::MineBuilder builder(&town, layout, config);
  for (const MineJunction& jn : layout.junctions) builder.junction(jn);
  for (std::size_t k = 0; k < layout.roadways.size(); ++k) builder.roadway(k);
  town.build_index();
  return town;
}

Town make_mine(std::uint64_t seed) {
  MineConfig c;
  c.seed = seed;
  return make_mine(c);
}

}  // namespace loopd
