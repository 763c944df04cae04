#pragma once
/// @file Each keyframe's pose as loopd publishes it (or its odometry pose), read from a map: shared by `trajectory`,
/// the map exports and `picture`.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "loopd/store/map_store.hpp"

namespace loopd::tools {

/// @brief One keyframe's pose.
struct KeyframePose {
  KeyframeKey key;
  std::int64_t utime = 0;  ///< [us] scan time
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  bool retired = false;  ///< retired by the place density policy: no features, no map cloud
};

/// @brief The poses read and where they came from.
struct KeyframePoses {
  std::vector<KeyframePose> poses;
  std::int64_t correction_revision = 0;  ///< 0: the map holds no correction
  std::int64_t from_correction = 0;      ///< poses the stored correction holds
  std::int64_t after_correction = 0;     ///< poses mapped with the correction's T_map_odom (keyframes it does not cover)
};

/// @brief Every keyframe of `session` (all when nullopt), in key order: the stored correction's T_map_sensor where
/// it covers the keyframe, else T_map_odom * T_odom_sensor (identity before any correction), as loopd publishes a
/// later keyframe; T_odom_sensor with `odometry`. Progress on stderr when `progress`.
StoreStatus read_keyframe_poses(MapStore& store, bool odometry, std::optional<SessionId> session, bool progress, KeyframePoses* out);

}  // namespace loopd::tools
