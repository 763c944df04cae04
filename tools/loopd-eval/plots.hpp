#pragma once
#include <string>
#include <vector>

#include "loopd/eval/evaluation.hpp"

namespace loopd::tools {

/// @brief Writes the pictures of an evaluation into `dir` with gnuplot: trajectories.{png,svg} (top view: ground
///        truth, odometry, corrected, revisited ground truth, accepted loops as segments) and pr_curve.{png,svg}.
///        The data files and the gnuplot script stay beside them. Returns the files written; `error` explains a
///        missing gnuplot or a failed run.
std::vector<std::string> write_plots(const std::string& dir, const EvalInput& input, const EvalReport& report, std::string* error);

}  // namespace loopd::tools
