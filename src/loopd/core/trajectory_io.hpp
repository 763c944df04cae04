#pragma once
// Trajectory text files: KITTI (3x4 row-major [R | t] a line) and TUM (`t x y z qx qy qz qw` a line), KITTI times and
// calibration, and the KITTI camera-to-lidar pose conversion. One implementation for loopd-correct (correction),
// loopd-eval / kitti2lcm (eval), tests and benches; errors name the file and the 1-based line.
#include <Eigen/Geometry>
#include <cstdint>
#include <fstream>
#include <functional>
#include <istream>
#include <optional>
#include <string>
#include <vector>

namespace loopd {

enum class TrajectoryFormat {
  kKitti,  ///< 12 numbers a line: the 3x4 row-major [R | t] of T_world_sensor
  kTum,    ///< `t x y z qx qy qz qw` a line
};
std::optional<TrajectoryFormat> trajectory_format_from_string(const std::string& name);  ///< "kitti" / "tum"

/// @brief Parsed trajectory, or error = "<source>:<line>: <reason>" for the first malformed line.
struct TrajectoryFile {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> stamps;  ///< TUM times [s]; KITTI: line index
  std::string error;
};
/// @brief Blank lines and lines starting with '#' are skipped; KITTI rotations must be (close to) rotation matrices.
TrajectoryFile parse_trajectory(std::istream& in, TrajectoryFormat format, const std::string& source = "<input>");
TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format);
/// @brief Writes poses (TUM: with stamps [s], or the index when stamps are missing); returns an error message on
///        failure.
std::optional<std::string> write_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses,
                                            const std::vector<double>& stamps, TrajectoryFormat format);

/// @brief Writes a trajectory in TUM format, timestamp in seconds (utime / 1e6); readable by evo (`evo_ape tum`).
///        Writes min(utimes, poses) lines.
bool write_tum_trajectory(const std::string& path, const std::vector<std::int64_t>& utimes,
                          const std::vector<Eigen::Isometry3d>& poses, std::string* error);

/// @brief Writes a trajectory in KITTI format: 12 numbers per line, the 3x4 row-major [R | t].
bool write_kitti_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, std::string* error);

/// @brief Reads KITTI poses (12 numbers per line, 3x4 row-major, close to a rotation (1e-2), re-orthonormalised). Empty lines are not allowed
///        (except a trailing one): they would shift every later pose. Errors name the file and the 1-based line.
bool read_kitti_poses(const std::string& path, std::vector<Eigen::Isometry3d>* poses, std::string* error);

/// @brief Reads a KITTI times.txt (one timestamp in seconds per line, non-decreasing, |t| <= 1e11 s).
bool read_kitti_times(const std::string& path, std::vector<double>* seconds, std::string* error);

/// @brief Reads the velodyne-to-camera transform from a KITTI calib file: the line "Tr: <12 numbers>" (or
///        "Tr_velo_to_cam: ..."). Returns T_cam_velo.
bool read_kitti_calib_tr(const std::string& path, Eigen::Isometry3d* T_cam_velo, std::string* error);

/// @brief KITTI camera-frame poses to lidar poses: T_world_velo = Tr^-1 * P_cam * Tr (the world frame becomes the
///        lidar frame of the first scan when P_cam(0) is the identity).
std::vector<Eigen::Isometry3d> kitti_camera_to_lidar(const std::vector<Eigen::Isometry3d>& camera_poses,
                                                     const Eigen::Isometry3d& T_cam_velo);

/// @brief KITTI ground truth as lidar poses T_world_velo: read_kitti_poses(poses_path) (e.g. poses/00.txt) and
///        read_kitti_calib_tr(calib_path), then kitti_camera_to_lidar.
bool read_kitti_lidar_poses(const std::string& poses_path, const std::string& calib_path,
                            std::vector<Eigen::Isometry3d>* lidar_poses, std::string* error);

/// Building blocks for other line-numbered text formats (loops, residuals in loopd_correction).
namespace text {
/// @brief Splits a line into numbers. On a non-number or a non-finite value returns false with the token and a
///        reason ("'x' is not a number" / "non-finite value 'nan'").
bool parse_numbers(const std::string& line, std::vector<double>* out, std::string* bad_token, std::string* reason);
/// @brief True for blank lines and '#' comments.
bool skip_line(const std::string& line);
/// @brief "<source>:<line>: ".
std::string where(const std::string& source, int line);
/// @brief Opens a text file for reading; returns "" or "<path>: is a directory, not a file" / "<path>: cannot open".
std::string open_text_file(const std::string& path, std::ifstream* in);
/// @brief Reads `in` line by line, skipping blank and '#' lines, and calls on_numbers(numbers of the line), which
///        returns "" when the line is fine or the reason it is not. Returns "" or "<source>:<line>: <reason>" for the
///        first bad line (a non-number or non-finite value included).
std::string for_each_number_line(std::istream& in, const std::string& source,
                                 const std::function<std::string(const std::vector<double>&)>& on_numbers);
/// @brief 3x4 row-major [R | t] (12 values) to an isometry, R re-orthonormalised (files carry 6-9 digits).
Eigen::Isometry3d isometry_from_3x4(const double* v);
/// @brief As isometry_from_3x4, but rejects a rotation part that is not (close to, 1e-2) a rotation matrix.
bool checked_isometry_from_3x4(const double* v, Eigen::Isometry3d* T, std::string* reason);
}  // namespace text

}  // namespace loopd
