#pragma once
// Text formats for offline correction (tools/loopd-correct): KITTI / TUM trajectories, loops, residuals.
#include <Eigen/Geometry>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include "loopd/correction/loop_correction.hpp"

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
/// @brief Blank lines and lines starting with '#' are skipped.
TrajectoryFile parse_trajectory(std::istream& in, TrajectoryFormat format, const std::string& source = "<input>");
TrajectoryFile read_trajectory(const std::string& path, TrajectoryFormat format);
/// @brief Writes poses (TUM: with stamps, or the index when stamps are missing); returns an error message on failure.
std::optional<std::string> write_trajectory(const std::string& path, const std::vector<Eigen::Isometry3d>& poses,
                                            const std::vector<double>& stamps, TrajectoryFormat format);

/// @brief Loops a line: `query_index match_index` + 12 numbers of T_match_query (3x4 row-major).
struct LoopFile {
  std::vector<LoopConstraint> loops;
  std::string error;
};
LoopFile parse_loops(std::istream& in, const std::string& source = "<input>", int num_poses = -1);
LoopFile read_loops(const std::string& path, int num_poses = -1);  ///< num_poses >= 0 also checks the indices

/// @brief One residual a line (finite, >= 0).
struct ResidualFile {
  std::vector<double> residuals;
  std::string error;
};
ResidualFile parse_residuals(std::istream& in, const std::string& source = "<input>");
ResidualFile read_residuals(const std::string& path);

}  // namespace loopd
