// loopd-bench correct: milliseconds per loop-correction method (median / p95 over repeats) on a synthetic drifted
// drive of N keyframes (laps of a rounded rectangle, heading bias + random walk) with K true loops.
// Targets (issue #7): heuristic <= 1 ms for 5000 poses (Vlaminck 2019 reports 11 ms), graph <= 100 ms for 5000 poses, 20 loops.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>

#include "loopd/base/stopwatch.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/correction/pose_graph.hpp"
#include "loopd/correction/trajectory_tools.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using loopd::tools::fmt;

namespace {

/// One timed method: its milliseconds and the trajectory error it leaves.
struct Row {
  std::string name;
  tools::Summary ms;
  TrajectoryError error;
};

static void print_rows(const std::vector<Row>& rows, const TrajectoryError& before, int poses, std::size_t loops, bool json) {
  std::cout << "synthetic drive: " << poses << " keyframes, " << loops << " loops, pose error before: mean " << fmt(before.mean_closest)
            << " m, median " << fmt(before.median_closest) << " m, ATE " << fmt(before.ate_rmse) << " m\n";
  tools::Table table({"method", "median ms", "p95 ms", "max ms", "runs", "mean err [m]", "median err [m]", "ATE [m]"});
  nlohmann::json j{{"poses", poses},
                   {"loops", loops},
                   {"before", {{"mean_closest", before.mean_closest}, {"median_closest", before.median_closest}, {"ate_rmse", before.ate_rmse}}}};
  nlohmann::json methods = nlohmann::json::array();
  for (const Row& r : rows) {
    table.add({r.name, fmt(r.ms.median, 3), fmt(r.ms.p95, 3), fmt(r.ms.max, 3), std::to_string(r.ms.count), fmt(r.error.mean_closest),
               fmt(r.error.median_closest), fmt(r.error.ate_rmse)});
    methods.push_back({{"method", r.name},
                       {"median_ms", r.ms.median},
                       {"p95_ms", r.ms.p95},
                       {"max_ms", r.ms.max},
                       {"runs", r.ms.count},
                       {"mean_closest", r.error.mean_closest},
                       {"median_closest", r.error.median_closest},
                       {"ate_rmse", r.error.ate_rmse}});
  }
  std::cout << table.str();
  j["methods"] = methods;
  if (json) tools::print_json_line(j);
}

}  // namespace

int run_bench_correct(int argc, char** argv) {
  CLI::App app("loopd-bench correct: ms per loop-correction method", "loopd-bench correct");
  int poses = 5000, num_loops = 20, repeats = 20, graph_repeats = 7;
  std::uint64_t seed = 1;
  bool json = false, full = false;
  app.add_option("--poses", poses, "keyframes in the synthetic drive")->capture_default_str();
  app.add_option("--loops", num_loops, "true loops, spread evenly over the drive")->capture_default_str();
  app.add_option("--repeats", repeats, "timed runs of the heuristic")->capture_default_str();
  app.add_option("--graph-repeats", graph_repeats, "timed runs of each graph variant")->capture_default_str();
  app.add_option("--seed", seed, "drift seed")->capture_default_str();
  app.add_flag("--full", full, "also time the full (unreduced) pose graph, one node per keyframe (slow)");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  if (poses < 200 || num_loops < 1 || repeats < 1 || graph_repeats < 1) {
    std::cerr << "loopd-bench correct: need --poses >= 200, --loops >= 1, --repeats >= 1\n";
    return tools::kExitUsage;
  }

  const auto gt = make_lap_trajectory(poses);
  DriftConfig drift;
  drift.seed = seed;
  const DriftedTrajectory odom = inject_drift(gt, drift);
  const auto all_loops = find_ground_truth_loops(gt, 1.0, 100, 20, 0);
  if (all_loops.empty()) {
    std::cerr << "loopd-bench correct: the drive has no loops; use more --poses\n";
    return tools::kExitUsage;
  }
  std::vector<LoopConstraint> loops;
  for (int k = 0; k < num_loops; ++k)
    loops.push_back(all_loops[static_cast<std::size_t>(k) * all_loops.size() / static_cast<std::size_t>(num_loops)]);
  loops.erase(std::unique(loops.begin(), loops.end(), [](const auto& a, const auto& b) { return a.query_index == b.query_index; }), loops.end());

  std::vector<Row> rows;
  auto time_it = [&](const std::string& name, int runs, auto&& fn) {
    std::vector<double> ms;
    std::vector<Eigen::Isometry3d> out;
    fn(out);  // warm-up
    for (int r = 0; r < runs; ++r) {
      Stopwatch w;
      fn(out);
      ms.push_back(w.ms());
    }
    rows.push_back({name, tools::summarize(ms), trajectory_error(out, gt)});
  };

  const HeuristicCorrectionConfig hcfg;
  const PoseGraphConfig gcfg;
  // One loop over the whole drive (the last one): the paper's single correction.
  time_it("heuristic, 1 loop", repeats, [&](auto& out) { out = correct_heuristic(odom.poses, odom.residuals, loops.back(), hcfg); });
  time_it("heuristic, all loops", repeats, [&](auto& out) { out = correct_heuristic_all(odom.poses, odom.residuals, loops, hcfg); });
  const auto warm = correct_heuristic_all(odom.poses, odom.residuals, loops, hcfg);
  time_it("graph (warm start), all loops", graph_repeats,
          [&](auto& out) { out = optimize_pose_graph(odom.poses, odom.residuals, loops, warm, gcfg).poses; });
  time_it("graph (odometry start), all loops", graph_repeats,
          [&](auto& out) { out = optimize_pose_graph(odom.poses, odom.residuals, loops, {}, gcfg).poses; });
  time_it("heuristic+graph, all loops", graph_repeats, [&](auto& out) {
    out = optimize_pose_graph(odom.poses, odom.residuals, loops, correct_heuristic_all(odom.poses, odom.residuals, loops, hcfg), gcfg).poses;
  });
  if (full) {
    PoseGraphConfig fcfg;
    fcfg.reduce_chains = false;
    time_it("full graph (warm start), all loops", std::min(graph_repeats, 3),
            [&](auto& out) { out = optimize_pose_graph(odom.poses, odom.residuals, loops, warm, fcfg).poses; });
  }
  // Online: LoopCorrector re-correcting on each new loop (heuristic+graph), latency per loop.
  {
    std::vector<double> ms;
    LoopCorrector corrector;
    for (std::size_t i = 0; i < odom.poses.size(); ++i) corrector.add_keyframe(odom.poses[i], odom.residuals[i]);
    for (const auto& l : loops) {
      Stopwatch w;
      corrector.add_loop(l);
      ms.push_back(w.ms());
    }
    rows.push_back({"online heuristic+graph, per loop", tools::summarize(ms), trajectory_error(corrector.corrected_poses(), gt)});
  }

  print_rows(rows, trajectory_error(odom.poses, gt), poses, loops.size(), json);
  return 0;
}
