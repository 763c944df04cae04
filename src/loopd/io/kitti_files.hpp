#pragma once
// KITTI odometry sequence text files besides the poses (which base/trajectory_io.hpp reads as kKitti): times.txt,
// the velodyne-to-camera calibration Tr, and the camera-frame poses converted to lidar poses. Errors name the file and
// the 1-based line.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "loopd/base/trajectory_io.hpp"

namespace loopd {

/// @brief KITTI times.txt: seconds, or ok == false with the reason.
struct KittiTimes {
  std::vector<double> seconds;
  bool ok = false;
  std::string error;
};
/// @brief Reads a KITTI times.txt with the trajectory rules (blank and '#' lines skipped): one timestamp in seconds a
///        line, non-decreasing, |t| <= 1e11 s (microsecond stamps stay in int64).
KittiTimes read_kitti_times(const std::string& path);

/// @brief The velodyne-to-camera transform of a KITTI calib file, or ok == false with the reason.
struct KittiCalibration {
  Eigen::Isometry3d T_cam_velo = Eigen::Isometry3d::Identity();
  bool ok = false;
  std::string error;
};
/// @brief Reads the line "Tr: <12 numbers>" (or "Tr_velo_to_cam: ...") of a KITTI calib file; other lines are
///        ignored. The rotation follows the trajectory rule (within 1e-2 of a rotation, re-orthonormalised).
KittiCalibration read_kitti_calib_tr(const std::string& path);

/// @brief KITTI camera-frame poses to lidar poses: T_world_velo = Tr^-1 * P_cam * Tr (the world frame becomes the
///        lidar frame of the first scan when P_cam(0) is the identity).
std::vector<Eigen::Isometry3d> kitti_camera_to_lidar(const std::vector<Eigen::Isometry3d>& camera_poses, const Eigen::Isometry3d& T_cam_velo);

/// @brief KITTI ground truth as lidar poses T_world_velo: read_kitti_calib_tr(calib_path), then
///        read_trajectory(poses_path, kKitti) (e.g. poses/00.txt), then kitti_camera_to_lidar. stamps: the pose index.
TrajectoryFile read_kitti_lidar_poses(const std::string& poses_path, const std::string& calib_path);

}  // namespace loopd
