#pragma once
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "loopd/keyframe/keyframe_key.hpp"

namespace loopd {

/// @brief Candidate selection before any descriptor is compared.
///        Radius: Vlaminck 2019 Sec. 4 (10% of the distance travelled since the last loop), clamped.
///        Index and travelled-distance gaps: Ren 2019 Sec. 3.4.1 rules.
struct DistanceGateConfig {
  double travel_fraction = 0.10;  ///< radius = fraction x distance since the last accepted loop (Vlaminck 2019)
  double min_radius = 8.0;        ///< [m] lower clamp
  double max_radius = 40.0;       ///< [m] upper clamp
  int min_index_gap = 30;         ///< keyframes between query and candidate of one session (Ren 2019 rule 1)
  double min_travel_gap = 60.0;   ///< [m] travelled distance between query and candidate (Ren 2019 rule 2)
  std::optional<std::string> validate() const;
};

/// @brief One keyframe as the gate sees it.
struct GateEntry {
  KeyframeKey key;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< current best estimate [m]
  double travelled = 0.0;                              ///< odometry distance from the first keyframe [m]
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
  /// @brief Keyframes within `radius` of `query` that satisfy the index and travel gaps (within one session) and
  /// `accept` (empty: all), nearest first.
  std::vector<GateCandidate> candidates(const GateEntry& query, double radius, const std::function<bool(const KeyframeKey&)>& accept = {}) const;
  std::size_t size() const { return entries_.size(); }

 private:
  using CellKey = std::int64_t;
  CellKey key(const Eigen::Vector3d& p) const;
  void rebuild();

  DistanceGateConfig config_;
  std::vector<GateEntry> entries_;
  std::unordered_map<CellKey, std::vector<std::size_t>> cells_;
};

}  // namespace loopd
