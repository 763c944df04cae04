// loopd-correct: offline loop correction of a trajectory (Vlaminck 2019 Sec. 4.4 heuristic and/or a pose graph).
#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "loopd/base/stopwatch.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/correction/loop_file.hpp"
#include "loopd/correction/trajectory_tools.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using loopd::tools::fmt;

namespace {
int fail(const std::string& message) {  // bad input: the exit status table (exit_codes.hpp)
  std::cerr << "loopd-correct: " << message << "\n";
  return tools::kExitUsage;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-correct: corrects a drifted trajectory with verified loops (heuristic of Vlaminck 2019 and/or a pose graph)"};
  std::string odometry_path, loops_path, out_path, residuals_path, ground_truth_path, method_name = "heuristic+graph", format_name = "kitti";
  bool json = false;
  LoopCorrectorConfig config;
  app.add_option("--odometry", odometry_path, "odometry keyframe poses (KITTI: 12 numbers a line; TUM: t x y z qx qy qz qw)")->required();
  app.add_option("--loops", loops_path, "loops, one a line: query_index match_index + 12 numbers of T_match_query (3x4 row-major)")->required();
  app.add_option("--out", out_path, "corrected poses, same format as --odometry")->required();
  app.add_option("--residuals", residuals_path, "scan-matching residual of the step ending at each pose, one a line (default: unknown)");
  app.add_option("--method", method_name, "heuristic | graph | heuristic+graph")->capture_default_str();
  app.add_option("--format", format_name, "kitti | tum")->capture_default_str();
  app.add_option("--ground-truth", ground_truth_path, "optional ground truth (same format) to print the pose error before/after");
  app.add_option("--loss-scale", config.graph.loop_loss_scale, "robust kernel scale on loop edges [sigmas]")->capture_default_str();
  app.add_flag("--json", json, "print one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  const auto method = correction_method_from_string(method_name);
  if (!method) return fail("unknown --method '" + method_name + "' (heuristic, graph, heuristic+graph)");
  const auto format = trajectory_format_from_string(format_name);
  if (!format) return fail("unknown --format '" + format_name + "' (kitti, tum)");
  config.method = *method;
  if (auto e = config.validate()) return fail(*e);

  const TrajectoryFile odometry = read_trajectory(odometry_path, *format);
  if (!odometry.ok) return fail(odometry.error);
  const int n = static_cast<int>(odometry.poses.size());
  const LoopFile loops = read_loops(loops_path, n);
  if (!loops.ok) return fail(loops.error);
  std::vector<double> residuals;
  if (!residuals_path.empty()) {
    const ResidualFile r = read_residuals(residuals_path);
    if (!r.ok) return fail(r.error);
    if (static_cast<int>(r.residuals.size()) != n)
      return fail(residuals_path + ": " + std::to_string(r.residuals.size()) + " residuals for " + std::to_string(n) + " poses (need one per pose)");
    residuals = r.residuals;
  }
  TrajectoryFile ground_truth;
  if (!ground_truth_path.empty()) {
    ground_truth = read_trajectory(ground_truth_path, *format);
    if (!ground_truth.ok) return fail(ground_truth.error);
  }

  LoopCorrector corrector(config);
  for (int i = 0; i < n; ++i)
    corrector.add_keyframe(odometry.poses[static_cast<std::size_t>(i)], residuals.empty() ? 0.0 : residuals[static_cast<std::size_t>(i)]);
  Stopwatch watch;
  const CorrectionResult result = corrector.add_loops(loops.loops);
  const double ms = watch.ms();
  if (auto e = write_trajectory(out_path, corrector.corrected_poses(), odometry.stamps, *format)) return fail(*e);

  double worst_t = 0.0, worst_r = 0.0;
  for (const auto& l : corrector.loops()) {
    const auto [t, r] = loop_end_error(corrector.corrected_poses(), l);
    worst_t = std::max(worst_t, t);
    worst_r = std::max(worst_r, r);
  }
  tools::Table table({"poses", "loops", "method", "ms", "heuristic ms", "graph ms", "graph iterations", "worst loop end [m]", "[deg]"});
  table.add({std::to_string(n), std::to_string(corrector.loops().size()), to_string(*method), fmt(ms, 2), fmt(result.ms_heuristic, 2),
             fmt(result.ms_graph, 2), std::to_string(result.graph_iterations), fmt(worst_t, 4), fmt(worst_r * 180.0 / M_PI, 4)});
  std::cout << table.str();
  nlohmann::json j{{"poses", n},
                   {"loops", corrector.loops().size()},
                   {"method", to_string(*method)},
                   {"ms", ms},
                   {"ms_heuristic", result.ms_heuristic},
                   {"ms_graph", result.ms_graph},
                   {"graph_iterations", result.graph_iterations},
                   {"graph_converged", result.graph_converged},
                   {"worst_loop_end_m", worst_t},
                   {"worst_loop_end_deg", worst_r * 180.0 / M_PI},
                   {"out", out_path}};
  if (!result.reason.empty()) std::cerr << "loopd-correct: " << result.reason << "\n";
  if (!ground_truth.poses.empty()) {
    const TrajectoryError before = trajectory_error(odometry.poses, ground_truth.poses);
    const TrajectoryError after = trajectory_error(corrector.corrected_poses(), ground_truth.poses);
    tools::Table err({"pose error [m]", "mean closest", "median closest", "max closest", "ATE rmse"});
    err.add({"before", fmt(before.mean_closest), fmt(before.median_closest), fmt(before.max_closest), fmt(before.ate_rmse)});
    err.add({"after", fmt(after.mean_closest), fmt(after.median_closest), fmt(after.max_closest), fmt(after.ate_rmse)});
    std::cout << err.str();
    j["before"] = {{"mean_closest", before.mean_closest}, {"median_closest", before.median_closest}, {"ate_rmse", before.ate_rmse}};
    j["after"] = {{"mean_closest", after.mean_closest}, {"median_closest", after.median_closest}, {"ate_rmse", after.ate_rmse}};
  }
  if (json) tools::print_json_line(j);
  return 0;
}
