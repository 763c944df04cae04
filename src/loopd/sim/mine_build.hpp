#pragma once
/// @file Internals of make_mine shared by mine.cpp (layout, roadways) and mine_junctions.cpp (chambers and their
/// features). Not part of the public API.
#include <cstdint>
#include <vector>

#include "loopd/sim/mine.hpp"

namespace loopd::detail {

/// Counter-based generator (as the town's): deterministic on every platform.
class MineRng {
 public:
  explicit MineRng(std::uint64_t seed) : state_(mix64(seed ^ 0x3141E5EEDull)) {}
  std::uint64_t next() { return mix64(state_ += 0x9E3779B97F4A7C15ull); }
  double uniform() { return hash_uniform(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }

 private:
  std::uint64_t state_;
};

constexpr double kMineRock = 4.5;  ///< [m] rock thickness behind every wall and roof face (deeper than any niche)

/// A roadway in its own frame: u along the axis (world x or y), v lateral (world y or x) from the centre line.
struct RoadFrame {
  bool along_x = true;
  double vc = 0.0;            ///< [m] world coordinate of the centre line across the axis
  double u0 = 0.0, u1 = 0.0;  ///< [m] axis coordinates of the chamber edges the roadway runs between
  double hw = 2.5, h = 4.5;   ///< [m] nominal half-width and height
};

/// A niche in a roadway wall: [u0, u1] along its axis on side `side` (+1 / -1 along v), `depth` [m] beyond the wall.
struct MineNiche {
  std::size_t roadway = 0;
  int side = 1;
  double u0 = 0.0, u1 = 0.0, depth = 2.5;
};

/// Axis-aligned box primitive between two corners (any order).
Primitive mine_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b, float reflectivity);

/// Builds the mine's primitives into *town: junctions first (they choose the niches), then the roadways.
class MineBuilder {
 public:
  MineBuilder(Town* town, const MineLayout& layout, const MineConfig& config);
  /// Chamber walls and roof, corner features, a door frame, a niche with its contents (mine_junctions.cpp).
  void junction(const MineJunction& jn);
  /// Rough walls (with the niches chosen so far) and roof of roadway k between its two chambers (mine.cpp).
  void roadway(std::size_t k);

 private:
  RoadFrame frame(const MineRoadway& r) const;
  Primitive local_box(const RoadFrame& f, double u0, double u1, double v0, double v1, double z0, double z1, float refl) const;
  void wall_pieces(const RoadFrame& f, int side, double u0, double u1);
  void roof_pieces(const RoadFrame& f);
  void chamber_walls(const MineJunction& jn);
  void corner_feature(const MineJunction& jn, int sx, int sy);
  void niche(std::size_t roadway, bool at_start);
  void door_frame(std::size_t roadway, bool at_start);
  void vehicle(const RoadFrame& f, const MineNiche& n);
  /// An equipment box on the floor over [lo, hi]; a movable one stands `moved_by` [m] away when moved (variant 1).
  void equipment(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const Eigen::Vector2d& moved_by, bool movable);
  double opening(const MineJunction& jn, int di, int dj) const;  ///< half-width of the roadway leaving jn that way; 0 if none
  float rock() { return static_cast<float>(rng_.uniform(0.15, 0.35)); }

  Town& t_;
  const MineLayout& l_;
  const MineConfig& c_;
  MineRng rng_;
  std::vector<MineNiche> niches_;
};

}  // namespace loopd::detail
