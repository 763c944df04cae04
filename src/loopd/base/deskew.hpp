#pragma once
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief Motion compensation ("deskew") of one sweep from its per-point times and the sensor's pose stream.
struct DeskewConfig {
  bool enabled = true;             ///< deskew scans that carry per-point times (scans without them are never touched)
  double max_sweep = 0.5;          ///< [s] per-point times spanning more than this are not one sweep: not deskewed
  double max_extrapolation = 0.1;  ///< [s] beyond the first / last pose the motion continues at the velocity of the nearest pose pair, up
                                   ///< to this far (one 10 Hz sweep); farther: not deskewed
  double max_pose_gap = 0.25;      ///< [s] poses farther apart than this are not interpolated (2.5 periods of a 10 Hz odometry)
  int time_bins = 64;              ///< sensor poses at time_bins + 1 instants of the sweep, blended linearly per point; 0 = every point's own pose
  std::optional<std::string> validate() const;
};

/// @brief Why a sweep was left as it was.
enum class DeskewSkip {
  kNone,             ///< deskewed
  kDisabled,         ///< DeskewConfig::enabled is false
  kNoTimes,          ///< the scan has no per-point times
  kNoSpan,           ///< every finite time is 0: the scan is already in the sensor frame at its stamp
  kSweepTooLong,     ///< the times span more than max_sweep
  kPosesDoNotCover,  ///< the poses (with max_extrapolation) do not reach over the sweep, or leave a gap in it
};
const char* to_string(DeskewSkip skip);

/// @brief What deskew() did.
struct DeskewResult {
  bool applied() const { return skipped == DeskewSkip::kNone; }
  DeskewSkip skipped = DeskewSkip::kNone;
  std::size_t points_moved = 0;  ///< points whose coordinates changed
  double max_correction = 0.0;   ///< [m] largest distance a point moved
  double sweep = 0.0;            ///< [s] span of the per-point times
  double extrapolated = 0.0;     ///< [s] how far beyond the poses the motion was extrapolated
};

/// @brief T_odom_sensor at any time near a short run of poses: slerp of the rotation and lerp of the translation
///        between the bracketing poses; extrapolated at the velocity of the first / last pose pair.
class PoseTrack {
 public:
  /// @param poses sorted by utime (strictly increasing); @param origin_utime [us] time 0 of at().
  PoseTrack(const std::vector<StampedPose>& poses, std::int64_t origin_utime, double max_pose_gap);
  /// @brief The pose at `t` [s after origin_utime], or nullopt when it lies in a gap, beyond max_extrapolation of
  ///        the poses, or needs a velocity that the poses do not give. `extrapolated` [s]: how far beyond them.
  std::optional<Eigen::Isometry3d> at(double t, double max_extrapolation, double* extrapolated = nullptr) const;
  /// @brief Whether every time in [lo, hi] has a pose (no gap, within max_extrapolation); if so, how far [s] the ends
  ///        lie beyond the poses.
  std::optional<double> coverage(double lo, double hi, double max_extrapolation) const;

 private:
  std::vector<double> times_;  ///< [s] after origin_utime
  std::vector<Eigen::Isometry3d> poses_;
  double max_gap_;
};

/// @brief Moves every point p_i, measured at its time t_i, into the sensor frame at the scan's stamp:
///        p_i' = T_odom_sensor(utime)^-1 * T_odom_sensor(utime + t_i) * p_i. `poses`: T_odom_sensor around the sweep
///        (sorted, strictly increasing utime). The cloud is left bit for bit as it was when the result says skipped.
DeskewResult deskew(const DeskewConfig& config, const std::vector<StampedPose>& poses, std::int64_t utime, PointCloud* cloud);

/// @brief [min, max] of the finite per-point times [s]; {0, 0} when there are none.
std::pair<double, double> time_span(const PointCloud& cloud);

}  // namespace loopd
