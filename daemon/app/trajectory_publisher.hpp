#pragma once
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <loopd/trajectory_t.hpp>

#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/node_config.hpp"

namespace loopd {

/// @brief Counters of what was published.
struct TrajectoryPublisherStats {
  std::int64_t messages = 0;   ///< trajectory_t messages made
  std::int64_t snapshots = 0;  ///< of them full
  std::int64_t keyframes = 0;  ///< keyframe poses in all of them
};

/// @brief Turns each correction into a trajectory_t whose size does not grow with the map on every revision: T_map_odom
///        always, the keyframes whose corrected pose moved by more than a threshold since they were last published (or
///        are new), and every keyframe (full = true) for the first revision, when `snapshot_period` has passed since the
///        last snapshot, when the keyframe list changed other than by appending, and at the end (final_snapshot).
///        A consumer applying each message on top of the last full one holds every pose within the thresholds of the
///        exact corrected pose, and exactly it after a snapshot.
class TrajectoryPublisher {
 public:
  explicit TrajectoryPublisher(const TrajectoryPublisherConfig& config)
      : config_(config), min_turn_cos_(std::cos(config.min_turn_deg * M_PI / 180.0)) {}

  /// @brief The message for one correction; utime is its publication time [us] (the snapshot clock).
  trajectory_t make_message(const CorrectionOutput& correction, std::int64_t utime);
  /// @brief Every keyframe of the last correction when the last message was partial (the end of a replay), else nothing.
  std::optional<trajectory_t> final_snapshot(std::int64_t utime);
  /// @brief The end of a run's own correction (the final pose-graph solve): every keyframe.
  trajectory_t final_message(const CorrectionOutput& correction, std::int64_t utime);
  const TrajectoryPublisherStats& stats() const { return stats_; }

 private:
  bool snapshot_due(const CorrectionOutput& c, std::int64_t utime) const;
  void remember(const CorrectionOutput& correction);
  bool moved(std::size_t i, const Eigen::Isometry3d& T_map_sensor) const;
  trajectory_t build(const CorrectionOutput& c, std::int64_t utime, bool full);

  TrajectoryPublisherConfig config_;
  double min_turn_cos_;                              ///< cos(min_turn_deg): moved() compares against it for every keyframe of every revision
  std::vector<KeyframeKey> published_keys_;          ///< keyframes published so far, in the correction's order
  std::vector<Eigen::Isometry3d> published_poses_;   ///< the pose each of them was last published with
  std::optional<std::int64_t> last_snapshot_utime_;  ///< [us]
  CorrectionOutput last_;                            ///< the last correction (without its resume state)
  bool last_was_full_ = true;
  TrajectoryPublisherStats stats_;
};

}  // namespace loopd
