#pragma once
/// @file The map's occupancy octree: OctoMap (Hornung et al., Autonomous Robots 2013), the octree Ren 2019 Sec. 3.5
/// cites for its map. Keyframe clouds go in at their corrected poses with ray casting, so space a later scan sees
/// through (a parked car that left, a person who walked on) is free again. OctoMap's headers stay in the .cpp.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"

namespace loopd {

/// @brief Octree resolution, ray length and the sensor model (OctoMap's log-odds update, its defaults where not said).
struct OccupancyMapConfig {
  double resolution = 0.2;      ///< [m] leaf edge
  double ray_max_range = 30.0;  ///< [m] rays longer than this clear space only up to it; their end point is not inserted
  double prob_hit = 0.7;        ///< OctoMap's default
  double prob_miss = 0.4;       ///< OctoMap's default
  double clamping_min = 0.12;   ///< OctoMap's default
  double clamping_max = 0.97;   ///< OctoMap's default
  std::optional<std::string> validate() const;
};

/// @brief What the octree says about a place.
enum class Occupancy { kUnknown, kFree, kOccupied };

/// @brief A probabilistic occupancy octree (one thread at a time; insertion runs OctoMap's own OpenMP loop).
class OccupancyMap {
 public:
  explicit OccupancyMap(const OccupancyMapConfig& config);
  ~OccupancyMap();
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// @brief Ray-casts `cloud_world` (world frame) from `origin_world`: the end points' leaves are hit; the leaves each
  /// ray crosses up to `free_margin[i]` metres before its end point are missed (each leaf updated once per scan, a hit
  /// winning over a miss). The margin keeps a ray that grazes a surface (the ground far ahead) from clearing the
  /// surface's own leaves before it reaches its end point (ray_stop_margins). Rays are cast on OpenMP threads.
  /// @param free_margin one margin [m] a point, or empty: no margin.
  void insert_scan(const PointCloud& cloud_world, const Eigen::Vector3d& origin_world, const std::vector<float>& free_margin = {});
  /// @brief The leaf holding `p` after every insertion so far.
  Occupancy at(const Eigen::Vector3f& p) const;
  /// @brief 1 for each point of `cloud_world` that is finite and lies in a free leaf, else 0 (at() for every point,
  /// looked up on OpenMP threads: the tree is only read).
  std::vector<std::uint8_t> free_points(const PointCloud& cloud_world) const;
  /// @brief Writes OctoMap's binary format (.bt: maximum-likelihood occupied / free, pruned; octovis opens it).
  /// @return std::nullopt, or why not.
  std::optional<std::string> write_binary(const std::string& path);
  std::size_t leaves() const;
  std::size_t memory_bytes() const;
  double resolution() const { return config_.resolution; }

 private:
  struct Impl;
  OccupancyMapConfig config_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace loopd
