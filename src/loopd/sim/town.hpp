#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

/// @brief Settings of the procedural town. Everything is derived from `seed`: the same config gives the same town.
struct TownConfig {
  std::uint64_t seed = 1;
  int blocks_x = 8;               ///< blocks along x; street lines are numbered -3 .. blocks_x-3 (node 0 at x = 0)
  int blocks_y = 8;               ///< blocks along y; likewise
  double min_block = 50.0;        ///< [m] street-centre to street-centre spacing, lower bound
  double max_block = 75.0;        ///< [m] upper bound
  double road_width = 12.0;       ///< [m] kerb to kerb (two 4 m lanes + two 2 m parking lanes)
  double sidewalk_width = 3.5;    ///< [m]
  double kerb_height = 0.15;      ///< [m] sidewalks/blocks are raised by this much above the road
  double slope_x = 0.012;         ///< ground slope dz/dx (gentle, 1.2 %)
  double slope_y = -0.008;        ///< ground slope dz/dy
  double park_fraction = 0.15;    ///< share of blocks that are parks (wall + trees)
  double lot_fraction = 0.10;     ///< share of blocks that are parking lots (low wall, cars, poles)
  double car_occupancy = 0.5;     ///< probability that a kerb-side parking slot holds a car
  double movable_fraction = 0.5;  ///< share of parked cars that move or vanish between visits
  double bush_fraction = 0.35;    ///< share of block sides with bushes along the sidewalk (shown with vegetation on)
  double cell_size = 4.0;         ///< [m] edge of the 2D spatial-index cells
  std::optional<std::string> validate() const;
};

/// @brief Shape of a scene primitive.
enum class PrimitiveType : std::uint8_t {
  kBox,       ///< axis-aligned box: a = min corner, b = max corner
  kCylinder,  ///< vertical cylinder: a = (cx, cy, z_bottom), b.z() = z_top, radius (top cap closed)
  kSphere,    ///< a = centre, radius
  kSlab,      ///< raised ground patch: x in [a.x, b.x], y in [a.y, b.y], top = ground(x, y) + a.z (kerb faces on its sides)
};

/// @brief One analytic scene primitive.
struct Primitive {
  PrimitiveType type = PrimitiveType::kBox;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double radius = 0.0;           ///< [m] cylinder / sphere
  float reflectivity = 0.3f;     ///< in [0, 1]; intensity = reflectivity * (0.3 + 0.7 |cos incidence|)
  std::int32_t movable_id = -1;  ///< -1: static; else index of the movable object this primitive belongs to
  std::int32_t variant = 0;      ///< which state of the movable object this primitive shows
  bool windows = false;          ///< box facade with a window grid (glass: most returns lost) above its ground floor
  /// Foliage (tree crowns, bushes; spheres): porous when the lidar simulates vegetation (SensorEffects::vegetation);
  /// bushes (`bush`) are only there then, crowns are solid otherwise.
  bool vegetation = false;
  bool bush = false;
};

/// @brief A procedural scene: a sloped ground plane plus primitives indexed in a 2D uniform grid (walked by DDA).
///
/// Movable objects (parked cars) have `num_variants` states (0 = where it stood on visit 0, 1 = moved along the kerb,
/// 2 = gone); the state on a visit is active_variant(id, visit). Visit 0 always shows variant 0.
struct Town {
  std::string name;
  TownConfig config;
  double ground_z0 = 0.0, ground_gx = 0.0, ground_gy = 0.0;  ///< ground: z = z0 + gx x + gy y
  std::vector<Primitive> primitives;
  int num_movables = 0;
  int num_variants = 3;
  std::vector<double> street_x;  ///< [m] x of the north-south street centre lines (index i + street_origin_i = node i)
  std::vector<double> street_y;  ///< [m] y of the east-west street centre lines
  int street_origin_i = 0;       ///< index in street_x of node i = 0
  int street_origin_j = 0;       ///< index in street_y of node j = 0
  bool lane_markings = true;     ///< dashed centre lines (bright ground) on streets

  // 2D grid over the primitives' footprints (compressed rows: cell c holds cell_items[cell_start[c] .. cell_start[c+1])).
  double grid_x0 = 0.0, grid_y0 = 0.0, cell_size = 4.0;
  int grid_nx = 0, grid_ny = 0;
  std::vector<std::uint32_t> cell_start;
  std::vector<std::uint32_t> cell_items;
  double max_z = 0.0;  ///< [m] highest primitive top (rays above it hit nothing but may still hit ground)

  /// @brief Ground height below (x, y) [m] (kerbs not included).
  double ground_height(double x, double y) const { return ground_z0 + ground_gx * x + ground_gy * y; }
  /// @brief World position (x, y) of street node (i, j); i, j count street lines from node 0.
  Eigen::Vector2d node(int i, int j) const;
  /// @brief True when node (i, j) exists.
  bool has_node(int i, int j) const;
  /// @brief State of movable object `id` on `visit` (0 = original place, 1 = moved, 2 = gone).
  int active_variant(int movable_id, int visit) const;
  /// @brief (Re)builds the spatial index from `primitives`; called by the factories.
  void build_index();
};

/// @brief The procedural town for `seed` (default config otherwise). Deterministic.
/// @note Street grid with blocks of buildings (facade segments with varying set-backs = recesses, balconies),
///       parks (boundary walls, trees), parking lots; poles and trees on sidewalks, parked cars in parking lanes;
///       rows of bushes on the inner edge of some sidewalks (from their own random stream, after everything else, so
///       that the rest of the town is the same with or without them).
Town make_town(std::uint64_t seed);
/// @brief The town for a full config.
Town make_town(const TownConfig& config);
/// @brief A second town built to the same pattern (same generator, same statistics) but with no structure in common
/// with make_town(seed): different block sizes, buildings, trees and cars. For "similar looking but different place"
/// (false-positive) tests.
Town make_other_town(std::uint64_t seed);

/// @brief Settings of the straight featureless corridor (for registration degeneracy tests).
struct CorridorConfig {
  double length = 400.0;  ///< [m] along x, centred on x = 0
  double width = 8.0;     ///< [m] wall to wall (centred on y = 0)
  double height = 6.0;    ///< [m] floor to ceiling
  bool ceiling = true;    ///< a tunnel when true, an open canyon of two walls when false
  std::optional<std::string> validate() const;
};
/// @brief A long straight tunnel along x: flat floor at z = 0, two smooth walls and a ceiling. Any two poses that differ
/// only in x see (almost) the same geometry, so scan matching is degenerate along x.
Town make_corridor(const CorridorConfig& config = {});

/// @brief Sensor pose on a street of the town: starting at node (i, j), heading `direction` (0 = +x/east, 1 = +y/north,
/// 2 = -x/west, 3 = -y/south), `along` metres from the node, `lateral` metres to the left of the street centre line
/// (driving lane: -2), `sensor_height` above the ground; z axis along the ground normal, x axis forward.
/// For the corridor (no streets) the pose is at (along, lateral) heading +x.
Eigen::Isometry3d street_pose(const Town& town, int i, int j, int direction, double along, double lateral = -2.0, double sensor_height = 1.8);

/// @brief Sensor pose at planar (x, y) with heading yaw [rad], `sensor_height` above the town's ground, z along the
/// ground normal.
Eigen::Isometry3d ground_pose(const Town& town, double x, double y, double yaw, double sensor_height = 1.8);

namespace detail {
/// splitmix64 finaliser: a well-mixed 64-bit hash.
inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
inline std::uint64_t hash_combine(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b + 0x632BE59BD9B4E019ull)); }
/// Uniform in [0, 1) from a hash.
inline double hash_uniform(std::uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }
}  // namespace detail

}  // namespace loopd
