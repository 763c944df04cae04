#pragma once
/// @file A keyframe's cloud from a short window of scans when one scan is too narrow or too sparse for the place
/// descriptors and 4PCS (a Livox Avia's 70 deg cone, a few thousand returns): the deskewed scans of the last moments,
/// moved into the keyframe's sensor frame by odometry, as peer systems build a local submap for such sensors.
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/deskew.hpp"
#include "loopd/base/point_cloud.hpp"
#include "loopd/base/pose.hpp"

namespace loopd {

/// @brief When and how a keyframe's cloud becomes a submap.
struct KeyframeSubmapConfig {
  bool enabled = true;              ///< build submaps for narrow or sparse scans (scans of a spinning lidar are never either)
  double max_coverage_deg = 180.0;  ///< [deg] a scan whose returns cover less azimuth than this is narrow
  std::size_t min_points = 4000;    ///< a scan with fewer finite returns is sparse
  /// [s] earlier scans this close before the keyframe's are merged into it. On the simulated Avia block drive (400
  /// scans at 10 m/s): 1.0 s / 10 scans closes 65 loops with 1 wrong (merged odometry blurs the cloud), 0.5 s / 5 scans
  /// 68 of 68 (recall 0.98; without submaps 56 of 56, recall 0.83), 0.3 s / 3 scans 63 of 63.
  double window = 0.5;
  double max_travel = 5.0;  ///< [m] ... and no farther from it (odometry)
  int max_scans = 5;        ///< ... at most this many (the newest)
  int confirm = 5;          ///< scans in a row that switch submaps on (narrow or sparse) or off: one odd scan changes nothing
  std::optional<std::string> validate() const;
};

/// @brief One scan kept for later keyframes' submaps: as it came (deskewed when it is merged), with its odometry.
struct WindowScan {
  std::int64_t utime = 0;
  PointCloud cloud;
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  std::vector<StampedPose> sweep_poses;  ///< for deskew (empty: the scan has no per-point times)
};

/// @brief True when `scan` is too narrow (azimuth coverage) or too sparse (finite returns) to stand alone.
bool needs_submap(const PointCloud& scan, const KeyframeSubmapConfig& config);

/// @brief The recent scans of a narrow or sparse sensor (one ingest thread; not thread-safe).
class ScanWindow {
 public:
  explicit ScanWindow(const KeyframeSubmapConfig& config) : config_(config) {}
  /// @brief Keeps a scan (newer than every kept one); scans older than the window are let go.
  void push(std::shared_ptr<const WindowScan> scan);
  /// @brief The kept scans that belong to a keyframe at `utime` / `T_odom_keyframe`: within the window and the travel,
  /// at most max_scans of them, oldest first.
  std::vector<std::shared_ptr<const WindowScan>> recent(std::int64_t utime, const Eigen::Isometry3d& T_odom_keyframe) const;
  /// @brief Whether keyframes are submaps now, given whether this scan needs one (needs_submap): the mode changes after
  /// `confirm` scans in a row say so, so a sensor near a threshold does not mix submaps and single scans. Leaving
  /// submap mode lets the kept scans go.
  bool update_mode(bool scan_needs_submap);
  void clear() { scans_.clear(); }
  std::size_t size() const { return scans_.size(); }

 private:
  KeyframeSubmapConfig config_;
  std::deque<std::shared_ptr<const WindowScan>> scans_;
  bool submaps_ = false;
  int disagreeing_ = 0;
};

/// @brief Appends each earlier scan, deskewed with `deskew` (when it has times), in the keyframe's sensor frame
/// (T_odom_keyframe^-1 T_odom_scan) to `keyframe_cloud`, which must already be deskewed. Per-point times and ring
/// indices are dropped from the result (they no longer describe one sweep). @return the scans merged.
int merge_submap(const std::vector<std::shared_ptr<const WindowScan>>& earlier, const Eigen::Isometry3d& T_odom_keyframe, const DeskewConfig& deskew,
                 PointCloud* keyframe_cloud);

}  // namespace loopd
