#pragma once
/// @file Area-bounded maps (issue 33): which keyframes of one place a newly looped keyframe makes redundant. The map keeps
/// a bounded number of keyframes per place (position and heading), the newest view and the best-connected ones, so it
/// grows with the area covered and not with the hours driven.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "loopd/records/keyframe_key.hpp"

namespace loopd {

/// @brief The retirement policy. A place is the ball of `radius_per_spacing` keyframe spacings around a keyframe that
/// has just closed a loop (so it is tied to the keyframes it finds there), with the views within max_rotation_deg of its
/// own; of the keyframes seen there on other passes, at most `keep` stay (that keyframe included), the rest retire.
struct PlaceDensityConfig {
  bool enabled = true;
  /// Place radius in keyframe spacings (KeyframeSelector::spacing of the query's scan: 2 m for a car, down to 1 m
  /// walking through rooms). 0.75 spacing: every point of a pass lies within it of one of a later pass's keyframes, and
  /// one earlier pass has one or two keyframes in it.
  double radius_per_spacing = 0.75;
  /// [deg] views turned further than this from the new keyframe are another place (a street driven the other way)
  double max_rotation_deg = 45.0;
  /// Keyframes kept per place, the new one included (>= 1): the newest view (a changed scene is learned) and the
  /// best-connected.
  int keep = 2;
  /// Keyframes of the new keyframe's own session within this many place radii of travel belong to its own pass: never
  /// counted or retired by it.
  double same_pass_radii = 4.0;
  std::optional<std::string> validate() const;
};

/// @brief A keyframe of the place as the policy sees it.
struct PlaceKeyframe {
  KeyframeKey key;
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();  ///< corrected pose
  double travelled = 0.0;                                          ///< [m] odometry path length in its session
  int loops = 0;                                                   ///< accepted loops it is an end of
  bool retirable = true;  ///< false: counted but never retired (a read-only map's keyframes under --localize)
};

/// @brief What one place's thinning decided.
struct PlaceDensityResult {
  std::vector<KeyframeKey> retire;  ///< by rank, worst last
  int views = 0;                    ///< keyframes of other passes at the place (before retiring)
};

/// @brief The keyframes `newest` makes redundant among `near` (the active keyframes within `radius` of it in its map
/// frame, itself excluded). Ranking: the new keyframe first; then those that cannot be retired, then by accepted loops
/// (most first), then the newer (greater key) first; all after the first `keep` are retired.
PlaceDensityResult thin_place(const PlaceKeyframe& newest, const std::vector<PlaceKeyframe>& near, double radius, const PlaceDensityConfig& config);

}  // namespace loopd
