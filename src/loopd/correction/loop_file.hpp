#pragma once
// Text formats for offline correction (tools/loopd-correct): loops and residuals, with the line rules of
// base/number_lines.hpp (blank and '#' lines skipped; errors "<source>:<line>: <reason>"). Trajectories (KITTI / TUM)
// are read and written by loopd/base/trajectory_io.hpp.
#include <istream>
#include <string>
#include <vector>

#include "loopd/correction/loop_correction.hpp"

namespace loopd {

/// @brief Loops a line: `query_index match_index` + 12 numbers of T_match_query (3x4 row-major, a rotation within
///        1e-2, re-orthonormalised).
struct LoopFile {
  std::vector<LoopConstraint> loops;
  bool ok = false;
  std::string error;
};
LoopFile parse_loops(std::istream& in, const std::string& source = "<input>", int num_poses = -1);
LoopFile read_loops(const std::string& path, int num_poses = -1);  ///< num_poses >= 0 also checks the indices

/// @brief One residual a line (finite, >= 0).
struct ResidualFile {
  std::vector<double> residuals;
  bool ok = false;
  std::string error;
};
ResidualFile parse_residuals(std::istream& in, const std::string& source = "<input>");
ResidualFile read_residuals(const std::string& path);

}  // namespace loopd
