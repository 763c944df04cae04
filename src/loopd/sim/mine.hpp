#pragma once
/// @file The simulated underground mine: a grid of roadways (tunnels) with junction chambers, rough walls and roof, and
/// distinctive structure only at and near the junctions, so that a revisit at a junction can be registered while a
/// stretch mid-tunnel is degenerate along the tunnel axis (Ren et al. 2019 drove a VLP-16 through such roadways).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/sim/town.hpp"

namespace loopd {

/// @brief Settings of the procedural mine. Everything is derived from `seed`: the same config gives the same mine.
struct MineConfig {
  std::uint64_t seed = 1;
  int cells_x = 3;                  ///< grid cells along x: nodes i = 0 .. cells_x (3 x 2 cells = 12 junctions)
  int cells_y = 2;                  ///< grid cells along y: nodes j = 0 .. cells_y
  double min_spacing = 60.0;        ///< [m] junction to junction (centre lines), lower bound
  double max_spacing = 100.0;       ///< [m] upper bound
  double min_width = 4.0;           ///< [m] roadway width wall to wall, lower bound (drawn per roadway)
  double max_width = 6.0;           ///< [m] upper bound
  double min_height = 4.0;          ///< [m] roadway height floor to roof, lower bound (drawn per roadway)
  double max_height = 5.0;          ///< [m] upper bound
  double min_piece = 1.5;           ///< [m] length of one rough wall / roof piece along the roadway, lower bound
  double max_piece = 3.0;           ///< [m] upper bound
  double min_jitter = 0.05;         ///< [m] inset / outset of a piece from the nominal wall or roof, lower bound
  double max_jitter = 0.15;         ///< [m] upper bound
  double min_chamber_margin = 1.5;  ///< [m] junction chamber half-size beyond its widest roadway's half-width
  double max_chamber_margin = 3.0;  ///< [m] upper bound (different corner shapes from junction to junction)
  double vehicle_fraction = 0.7;    ///< share of niches holding a parked mine vehicle
  double movable_fraction = 0.6;    ///< share of vehicles and equipment boxes that move or vanish between visits
  double cell_size = 4.0;           ///< [m] edge of the 2D spatial-index cells
  std::optional<std::string> validate() const;
};

/// @brief One roadway: the tunnel between two neighbouring junctions.
struct MineRoadway {
  int i0 = 0, j0 = 0;  ///< first node
  int i1 = 0, j1 = 0;  ///< second node: (i0 + 1, j0) along x or (i0, j0 + 1) along y
  bool along_x = true;
  double width = 5.0;   ///< [m] wall to wall (nominal: pieces are inset / outset by the jitter)
  double height = 4.5;  ///< [m] floor to roof (nominal)
};

/// @brief One junction chamber: a square around node (i, j).
struct MineJunction {
  int i = 0, j = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  ///< [m] node position (crossing of the roadway centre lines)
  double half_size = 4.0;                            ///< [m] half the chamber's side (walls at centre +- half_size)
  double height = 4.5;                               ///< [m] chamber roof
};

/// @brief Where the roadways and junctions are: node (i, j) is at (line_x[i], line_y[j]), node (0, 0) at the origin.
struct MineLayout {
  std::vector<double> line_x, line_y;
  std::vector<MineRoadway> roadways;    ///< every grid edge: the x edges row by row, then the y edges
  std::vector<MineJunction> junctions;  ///< node (i, j) at index j * (cells_x + 1) + i
  /// @brief The roadway between two neighbouring nodes (either order); nullptr when there is none.
  const MineRoadway* roadway(int ia, int ja, int ib, int jb) const;
  /// @brief The junction at node (i, j); nullptr outside the grid.
  const MineJunction* junction(int i, int j) const;
};

/// @brief The layout of make_mine(config) (the same random draws). Deterministic.
MineLayout make_mine_layout(const MineConfig& config);

/// @brief The procedural mine for `seed` (default config otherwise). Deterministic.
/// @note A Town: the flat floor is the ground plane (z = 0), walls and roof are kBox primitives cut into 1.5-3 m pieces
///       inset / outset by 5-15 cm (rough, but self-similar along each roadway). Distinctive structure sits only in the
///       junction chambers and within ~12 m of them: pillars and rib pillars in the chamber corners, equipment boxes, a
///       niche in a roadway wall (often with a parked mine vehicle), ventilation door frames, a chamber roof above the
///       roadways' and a seeded chamber size. Vehicles and some equipment boxes are movable (variant 0 where they stood
///       on visit 0, 1 moved, 2 gone, as the town's parked cars). street_x / street_y hold the roadway centre lines,
///       so Town::node(i, j) is junction (i, j); no lane markings.
Town make_mine(std::uint64_t seed);
/// @brief The mine for a full config (an invalid config gives an empty mine named "mine-invalid").
Town make_mine(const MineConfig& config);

}  // namespace loopd
