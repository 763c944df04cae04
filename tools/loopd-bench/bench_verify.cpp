// loopd-bench verify: the whole verification (4PCS -> GICP -> degeneracy -> Hungarian) on simulated HDL-64E loop
// candidates, true revisits and near misses; median / p95 ms per stage, decisions, keyframe bytes.
#include <CLI/CLI.hpp>
#include <cmath>
#include <ctime>
#include <iostream>

#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/verify/verify.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {
struct Candidate {
  std::string name;
  bool is_loop;
  const Town* query_town;
  Eigen::Isometry3d Tq;
  int visit_q;
  const Town* match_town;
  Eigen::Isometry3d Tm;
  int visit_m;
};
}  // namespace

/// @brief The candidates: per street a same-direction revisit with cars moved, an opposite-direction one, one a lane
///        over, and near misses (another town, a tunnel 4-8 m on). Towns live as long as the program (static).
static std::vector<Candidate> make_candidates(int streets) {
  static const Town town = make_town(1), other = make_other_town(1), corridor = make_corridor();
  std::vector<Candidate> cands;
  for (int s = 0; s < streets; ++s) {
    const double along = 18.0 + 7.0 * s;
    const Eigen::Isometry3d Tq = street_pose(town, s, 0, 1, along);
    const double yaw = std::atan2(Tq.linear()(1, 0), Tq.linear()(0, 0));
    const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw)), left(-std::sin(yaw), std::cos(yaw));
    const Eigen::Vector2d opp = Tq.translation().head<2>() + 4.0 * left + 0.5 * fwd;
    const std::string tag = " " + std::to_string(s);
    cands.push_back({"same-dir, cars moved" + tag, true, &town, Tq, 0, &town, street_pose(town, s, 0, 1, along + 0.8, -1.7), 1});
    cands.push_back({"opposite-dir" + tag, true, &town, Tq, 0, &town, ground_pose(town, opp.x(), opp.y(), yaw + M_PI), 1});
    cands.push_back({"lane +3 m" + tag, true, &town, Tq, 0, &town, street_pose(town, s, 0, 1, along + 0.5, 1.0), 2});
    cands.push_back({"other town" + tag, false, &town, Tq, 0, &other, street_pose(other, s, 0, 1, along), 0});
    cands.push_back({"tunnel +" + std::to_string(4 + 2 * s) + " m", false, &corridor, street_pose(corridor, 0, 0, 0, 10.0 * s, 0.0), 0, &corridor,
                     street_pose(corridor, 0, 0, 0, 10.0 * s + 4 + 2 * s, 0.0), 0});
  }
  return cands;
}

int run_bench_verify(int argc, char** argv) {
  CLI::App app("loopd-bench verify: whole loop verification, ms per stage");
  int streets = 3, threads = 2;
  bool json = false;
  PrepareConfig prep;
  VerifyConfig cfg;
  app.add_option("--streets", streets, "streets of the simulated town to take candidates from (5 candidates each)")->capture_default_str();
  app.add_option("--threads", threads, "threads (normals, GICP, 4PCS scoring)")->capture_default_str();
  app.add_option("--voxel", prep.voxel_size, "voxel size [m]")->capture_default_str();
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  prep.num_threads = threads;
  cfg.gicp.num_threads = threads;
  cfg.four_pcs.num_threads = threads;

  const LidarModel model = lidar_model_hdl64();
  const std::vector<Candidate> cands = make_candidates(streets);

  std::vector<double> ms_fourpcs, ms_gicp, ms_hungarian, ms_total, cpu_total, ms_prepare, bytes;
  int correct = 0, true_accepted = 0, false_accepted = 0, loops = 0, misses = 0;
  tools::Table rows({"candidate", "loop?", "decision", "stage", "LCP", "fitness", "residual", "degeneracy", "consistency", "err m/deg", "4PCS ms",
                     "GICP ms", "total ms"});
  tools::Progress prog("verifying", static_cast<std::int64_t>(cands.size()), !json);
  int done = 0;
  for (const auto& c : cands) {
    Stopwatch sw;
    const PreparedScan q =
        prepare_scan(simulate_scan(*c.query_town, model, c.Tq, 31 + static_cast<std::uint64_t>(done), threads, c.visit_q), &model, prep);
    ms_prepare.push_back(sw.ms());
    const PreparedScan m =
        prepare_scan(simulate_scan(*c.match_town, model, c.Tm, 77 + static_cast<std::uint64_t>(done), threads, c.visit_m), &model, prep);
    bytes.push_back(static_cast<double>(q.bytes()));
    const double c0 = process_cpu_ms();
    const VerifyResult r = verify(q, m, cfg);
    cpu_total.push_back(process_cpu_ms() - c0);
    ms_fourpcs.push_back(r.ms_fourpcs);
    ms_gicp.push_back(r.ms_gicp);
    ms_hungarian.push_back(r.ms_hungarian);
    ms_total.push_back(r.ms_total);
    const Eigen::Isometry3d truth = c.Tm.inverse() * c.Tq;
    const double te = (r.T_match_query.translation() - truth.translation()).norm();
    const double re = std::abs(Eigen::AngleAxisd(Eigen::Matrix3d(r.T_match_query.linear().transpose() * truth.linear())).angle()) * 180.0 / M_PI;
    const bool good_accept = r.accepted && te < 0.2 && re < 1.0;
    loops += c.is_loop ? 1 : 0;
    misses += c.is_loop ? 0 : 1;
    true_accepted += c.is_loop && good_accept ? 1 : 0;
    false_accepted += !c.is_loop && r.accepted ? 1 : 0;
    correct += (c.is_loop ? good_accept : !r.accepted) ? 1 : 0;
    rows.add({c.name, c.is_loop ? "yes" : "no", r.accepted ? "accept" : "reject", to_string(r.stage), tools::fmt(r.lcp_fraction, 2),
              tools::fmt(r.icp_fitness, 2), tools::fmt(r.icp_residual, 3), tools::fmt(r.degeneracy, 1), tools::fmt(r.hungarian_consistency, 2),
              c.is_loop ? tools::fmt(te, 3) + "/" + tools::fmt(re, 2) : "-", tools::fmt(r.ms_fourpcs, 1), tools::fmt(r.ms_gicp, 1),
              tools::fmt(r.ms_total, 1)});
    prog.update(++done);
  }
  prog.finish();

  nlohmann::json j;
  tools::Table summary({"stage", "median ms", "p95 ms", "max ms"});
  auto add = [&](const std::string& name, const std::vector<double>& v) {
    const auto s = tools::summarize(v);
    summary.add({name, tools::fmt(s.median, 2), tools::fmt(s.p95, 2), tools::fmt(s.max, 2)});
    j["ms"][name] = {{"median", s.median}, {"p95", s.p95}, {"max", s.max}, {"mean", s.mean}};
  };
  add("fourpcs", ms_fourpcs);
  add("gicp", ms_gicp);
  add("hungarian", ms_hungarian);
  add("total", ms_total);
  add("total_cpu", cpu_total);
  add("prepare_scan", ms_prepare);
  const auto b = tools::summarize(bytes);
  j["keyframe_bytes"] = {{"median", b.median}, {"max", b.max}};
  j["candidates"] = cands.size();
  j["loops"] = loops;
  j["near_misses"] = misses;
  j["loops_accepted_correctly"] = true_accepted;
  j["near_misses_accepted"] = false_accepted;
  j["correct_decisions"] = correct;
  j["threads"] = threads;
  if (json) {
    tools::print_json_line(j);
    return 0;
  }
  std::cout << rows.str() << "\n" << summary.str();
  std::cout << "decisions: " << correct << "/" << cands.size() << " correct; true loops accepted within 0.2 m / 1 deg: " << true_accepted << "/"
            << loops << "; near misses accepted: " << false_accepted << "/" << misses << "\n";
  std::cout << "keyframe bytes (PreparedScan::bytes): median " << static_cast<long>(b.median) << ", max " << static_cast<long>(b.max) << "; "
            << threads << " threads; 2 shared cores, so ms depend on machine load (total_cpu = process CPU time of verify)\n";
  return 0;
}
