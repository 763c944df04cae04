#pragma once
// Private to loopd_eval: the keyframe steps of evaluate() (evaluation_keyframes.cpp): frame numbers, which keyframes
// are evaluated, and their ground-truth, odometry and corrected poses.
#include <Eigen/Geometry>
#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "loopd/eval/evaluation.hpp"

namespace loopd {
namespace detail {

/// @brief A copy of `poses` sorted by utime (stable: poses with equal stamps keep their order).
std::vector<StampedPose> sorted_by_time(const std::vector<StampedPose>& poses);

/// @brief Frame numbers: index of the scan in the drive (Vlaminck 2019, 5.3 counts poses of the sequence).
struct FrameIndex {
  std::vector<std::pair<std::int64_t, std::int64_t>> entries;  ///< (utime [us], frame), sorted; never empty

  /// @brief Frame of the scan nearest in time to `utime` (the later one on a tie).
  std::int64_t frame_of(std::int64_t utime) const;
};

/// @brief Frames from the drive's scans, or from the ground-truth poses (`gt`, sorted) when the drive has no scans.
FrameIndex build_frame_index(const std::vector<std::int64_t>& scan_utimes, const std::vector<StampedPose>& gt, std::vector<std::string>& warnings);

/// @brief Keyframes: the corrected trajectory's keyframes, the ends of every loop, and after the last revision the
/// scans at the trajectory's typical keyframe spacing; every scan when there is no corrected trajectory.
std::set<std::int64_t> select_keyframe_utimes(const EvalInput& in, const FrameIndex& frames, std::vector<std::string>& warnings);

/// @brief The last trajectory revision as T_map_sensor stamped poses, sorted by utime.
std::vector<StampedPose> corrected_trajectory(const std::vector<KeyframePose>& keyframes);

/// @brief The drive's trajectories, each sorted by utime.
struct SortedTrajectories {
  std::vector<StampedPose> gt;         ///< ground truth, T_world_sensor
  std::vector<StampedPose> odom;       ///< odometry, T_odom_sensor
  std::vector<StampedPose> corrected;  ///< last revision, T_map_sensor (empty without one)
};

/// @brief Odometry and corrected poses at the evaluated keyframes, before aligning them to ground truth.
struct RawKeyframePoses {
  std::vector<Eigen::Isometry3d> odom, after;
};

/// @brief Looks up ground truth, odometry and the corrected pose at every keyframe utime; keyframes without ground
/// truth or odometry are dropped (with a warning). Fills rep's keyframe_utimes, keyframe_frames and gt_keyframes.
RawKeyframePoses sample_keyframes(const std::set<std::int64_t>& kf, const SortedTrajectories& tr, const EvalInput& in, const FrameIndex& frames,
                                  const EvalConfig& config, EvalReport& rep);

/// @brief "Before" and "after" share the ground truth's frame by aligning their first keyframe to it.
void align_to_ground_truth(const RawKeyframePoses& raw, EvalReport& rep);

}  // namespace detail
}  // namespace loopd
