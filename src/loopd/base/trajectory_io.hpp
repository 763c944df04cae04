#pragma once
// Trajectory text files: KITTI (3x4 row-major [R | t] a line) and TUM (`t x y z qx qy qz qw` a line). The one reader
// and writer of poses files for loopd-correct, loopd-eval, kitti2lcm (ground truth and odometry), tests and benches.
//
// Rules (text::for_each_number_line, the same for every loopd text file):
//   - blank lines and lines starting with '#' are skipped (a KITTI pose's index counts poses, not lines);
//   - every other line holds exactly 12 (KITTI) or 8 (TUM) finite numbers;
//   - a KITTI rotation within 1e-2 of a rotation matrix (|R^T R - I|_F, det R > 0) is re-orthonormalised, any other
//     is rejected; a TUM quaternion must have |q| within 1e-2 of 1 and is normalised;
//   - a file without poses is an error.
// Errors name the file and the 1-based line: "<path>:<line>: <reason>".
#include <Eigen/Geometry>
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

/// @brief Parsed trajectory, or ok == false and error = "<source>:<line>: <reason>" for the first malformed line.
struct TrajectoryFile {
  std::vector<Eigen::Isometry3d> poses;  ///< T_world_sensor
  std::vector<double> stamps;            ///< TUM times [s]; KITTI: the pose index
  bool ok = false;
  std::string error;
};
TrajectoryFile parse_trajectory(std::istream& in, TrajectoryFormat format, const std::string& source = "<input>");
TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format);

/// @brief Writes poses (TUM: with stamps [s], or the index when stamps are missing; KITTI: stamps unused).
/// @return std::nullopt, or "<path>: cannot open for writing" / "<path>: write failed".
std::optional<std::string> write_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses, const std::vector<double>& stamps,
                                            TrajectoryFormat format);

}  // namespace loopd
