#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief Candidate selection before any descriptor is compared.
///        Radius: Vlaminck 2019 Sec. 4 (10% of the distance travelled since the last loop), clamped.
///        Index and travelled-distance gaps: Ren 2019 Sec. 3.4.1 rules.
struct DistanceGateConfig {
  double travel_fraction = 0.10;  ///< radius = fraction x distance since the last accepted loop (Vlaminck 2019)
  double min_radius = 8.0;        ///< [m] lower clamp
  double max_radius = 40.0;       ///< [m] upper clamp
  int min_index_gap = 30;         ///< keyframes between query and candidate of one session (Ren 2019 rule 1)
  double min_travel_gap = 60.0;   ///< [m] travelled distance between query and candidate (Ren 2019 rule 2), at car scale
  /// Scale from the scene: the travel gap is min(min_travel_gap, max(min_travel_gap_floor, this x the query scan's
  /// scene_scale(), travel_gap_per_radius x the gate radius)), so a walk through a courtyard (scale 10-20 m) closes a
  /// revisit after 25-30 m while a car in a street (40-80 m) keeps Ren's 60 m. The index gap shrinks in the same
  /// proportion (to no fewer than 5). 0: off.
  double travel_gap_per_scale = 1.5;
  /// A revisit is a return after going away: never less travel than this many gate radii, so a keyframe a few metres
  /// back along a self-similar tunnel (scene scale 3-6 m) is no candidate. In the simulated mine (1000 VLP-16 scans)
  /// the scaled gap alone let 2 wrong loops of 42 through; with 3 radii none.
  double travel_gap_per_radius = 3.0;
  double min_travel_gap_floor = 8.0;  ///< [m] the scaled travel gap is never below this
  std::optional<std::string> validate() const;
};

/// @brief One keyframe as the gate sees it.
struct GateEntry {
  KeyframeKey key;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< current best estimate [m]
  double travelled = 0.0;                              ///< odometry distance from the first keyframe [m]
  bool retired = false;                                ///< retire(): in no cell, never a candidate again
};

/// @brief Candidate returned by the gate.
struct GateCandidate {
  KeyframeKey key;
  double distance = 0.0;  ///< [m] between the estimated positions
};

/// @brief Spatial hash of keyframe positions (cells of max_radius) answering "which earlier keyframes
///        lie within r of here", so the gate is not a linear scan over all keyframes.
class DistanceGate {
 public:
  explicit DistanceGate(const DistanceGateConfig& config) : config_(config) {}

  /// @brief Gate radius for the current distance since the last accepted loop [m].
  double radius(double travelled_since_loop) const;
  /// @brief Adds a keyframe (newer than every keyframe of its session already added).
  void add(const GateEntry& entry);
  /// @brief Replaces every stored position with position_of(key) (after a loop correction).
  void update_positions(const std::function<Eigen::Vector3d(const KeyframeKey&)>& position_of);
  /// @brief Replaces the stored positions of the entries from `first` on (in the order added) with position_of(entry):
  /// after a correction that moved only those. An entry moves to another cell only when its cell changed, so the cost
  /// is the moved entries', not the map's; the same candidates as update_positions.
  void update_positions_from(std::size_t first, const std::function<Eigen::Vector3d(std::size_t entry)>& position_of);
  /// @brief Keyframes within `radius` of `query` that satisfy the index and travel gaps (within one session) and
  /// `accept` (empty: all), nearest first.
  /// @param travel_gap [m] the travel gap for this query (travel_gap()); negative: config's min_travel_gap.
  std::vector<GateCandidate> candidates(const GateEntry& query, double radius, const std::function<bool(const KeyframeKey&)>& accept = {},
                                        double travel_gap = -1.0) const;
  /// @brief Keyframes within `radius` of `position` (3D), no gap applied, nearest first (a place's keyframes).
  std::vector<GateCandidate> within(const Eigen::Vector3d& position, double radius) const;
  /// @brief Entry `entry` (in the order added) leaves its cell for good: never a candidate or within() again (a
  /// retired keyframe). Its position is still updated, so entries keep their order. False when out of range or retired.
  bool retire(std::size_t entry);
  /// @brief [m] The travel gap for a query whose scan has this scene scale (0: unknown, the configured gap) at this
  /// gate radius.
  double travel_gap(double scene_scale, double radius) const;
  std::size_t size() const { return entries_.size(); }

 private:
  using CellKey = std::int64_t;
  CellKey key(const Eigen::Vector3d& p) const;
  void rebuild();
  /// Calls visit(entry) for every entry in the cells that can hold one within max_radius of `position`.
  template <typename Visit>
  void for_each_near(const Eigen::Vector3d& position, Visit&& visit) const;

  DistanceGateConfig config_;
  std::vector<GateEntry> entries_;
  std::unordered_map<CellKey, std::vector<std::size_t>> cells_;
};

}  // namespace loopd
