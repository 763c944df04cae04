#pragma once
/// @file Localizing in a map (loopd --localize): what the engine's results say about where this run lies in the map,
/// one state per keyframe once its decisions and their correction are in.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

/// @brief Where one keyframe of this run lies in the map, and how sure that is (mirrored by localization_t).
struct LocalizationState {
  KeyframeKey keyframe;
  std::int64_t utime = 0;                  ///< [us] the keyframe's scan time
  bool localized = false;                  ///< a loop tied this run's session to the map
  std::int64_t localized_since_utime = 0;  ///< [us] scan time of the keyframe it was first tied at (0: not localized)
  std::int64_t loops_to_map = 0;           ///< accepted loops from this run's keyframes to another session's (the map's)
  std::int64_t last_loop_utime = 0;        ///< [us] the newest such loop's query scan time (0: none)
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
};

/// @brief Follows the engine's results for one run (EngineSink order: keyframe, its decisions, its correction,
/// decided). Not thread-safe: the sink calls it one call at a time.
class LocalizationTracker {
 public:
  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor);
  void on_decision(const LoopDecision& decision);
  void on_correction(const CorrectionOutput& correction);
  /// @brief The keyframe's state, once: nullopt for another key than the newest keyframe's.
  std::optional<LocalizationState> on_keyframe_decided(const KeyframeKey& key);

 private:
  std::optional<LocalizationState> pending_;                         ///< the newest keyframe, until decided
  Eigen::Isometry3d T_odom_sensor_ = Eigen::Isometry3d::Identity();  ///< of the pending keyframe
  bool localized_ = false;
  std::int64_t localized_since_utime_ = 0, loops_to_map_ = 0, last_loop_utime_ = 0;
};

}  // namespace loopd
