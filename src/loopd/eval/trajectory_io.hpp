#pragma once
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace loopd {

/// @brief Writes a trajectory in TUM format: "timestamp tx ty tz qx qy qz qw" per line, timestamp in seconds
///        (utime / 1e6). Readable by evo (`evo_ape tum`).
bool write_tum_trajectory(const std::string& path, const std::vector<std::int64_t>& utimes,
                          const std::vector<Eigen::Isometry3d>& poses, std::string* error);

/// @brief Writes a trajectory in KITTI format: 12 numbers per line, the 3x4 row-major [R | t].
bool write_kitti_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, std::string* error);

/// @brief Reads KITTI poses (12 numbers per line, 3x4 row-major). Empty lines are not allowed; errors name the
///        file and the 1-based line number.
bool read_kitti_poses(const std::string& path, std::vector<Eigen::Isometry3d>* poses, std::string* error);

/// @brief Reads a KITTI times.txt (one timestamp in seconds per line).
bool read_kitti_times(const std::string& path, std::vector<double>* seconds, std::string* error);

/// @brief Reads the velodyne-to-camera transform from a KITTI calib file: the line "Tr: <12 numbers>" (or
///        "Tr_velo_to_cam: ..."). Returns T_cam_velo.
bool read_kitti_calib_tr(const std::string& path, Eigen::Isometry3d* T_cam_velo, std::string* error);

/// @brief KITTI camera-frame poses to lidar poses: T_world_velo = Tr^-1 * P_cam * Tr (the world frame becomes the
///        lidar frame of the first scan when P_cam(0) is the identity).
std::vector<Eigen::Isometry3d> kitti_camera_to_lidar(const std::vector<Eigen::Isometry3d>& camera_poses,
                                                     const Eigen::Isometry3d& T_cam_velo);

}  // namespace loopd
