// loopd-bench gicp: loopd's GICP vs pcl::GeneralizedIterativeClosestPoint on the same pairs and initial guesses
// (final error and ms, median / p95). Pairs: simulated HDL-64E revisits (same direction, opposite direction, lane
// offset, moved parked cars) prepared like keyframes (prepare_scan), started from the ground truth perturbed by up to
// 0.5 m / 5 deg (a 4PCS-sized error); plus consecutive real KITTI scans when the data folder is present.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/io/kitti_files.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/registration/gicp.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "pcl_peers_gicp.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {

struct Pair {
  std::string name;
  PreparedScan source, target;
  Eigen::Isometry3d truth;  // T_target_source
  std::vector<Eigen::Isometry3d> inits;
};

double rot_err_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::abs(Eigen::AngleAxisd(Eigen::Matrix3d(a.linear().transpose() * b.linear())).angle()) * 180.0 / M_PI;
}

/// @brief The initial guesses of a pair: the truth moved 0.5 m and turned 5 deg (alternating sides) and up to 1 deg in
///        roll and pitch, from one seeded generator over all pairs.
struct Perturbations {
  int per_pair = 2;
  std::mt19937 rng{7};
  std::uniform_real_distribution<double> u{-1.0, 1.0};
  void add(Pair* p) {
    for (int k = 0; k < per_pair; ++k) {
      Eigen::Vector3d t(u(rng), u(rng), 0.2 * u(rng));
      t *= 0.5 / std::max(1e-9, t.norm());  // 0.5 m
      const double yaw = 5.0 * M_PI / 180.0 * (k % 2 == 0 ? 1 : -1), small = 1.0 * M_PI / 180.0 * u(rng);
      p->inits.push_back(p->truth * make_isometry(t.x(), t.y(), t.z(), yaw, small, -small));
    }
  }
};

/// @brief Simulated HDL-64E revisits: street k of the grid, alternating same direction / opposite direction / lane
///        offset; visit 1 moves parked cars.
std::vector<Pair> simulated_pairs(int num_pairs, int threads, const PrepareConfig& prep, Perturbations& perturb, bool progress) {
  std::vector<Pair> pairs;
  const LidarModel model = lidar_model_hdl64();
  const Town town = make_town(1);
  tools::Progress prog("simulating pairs", num_pairs, progress);
  for (int i = 0; i < num_pairs; ++i) {
    const int street = i / 3, kind = i % 3;
    const double along = 18.0 + 7.0 * street;
    const Eigen::Isometry3d Tq = street_pose(town, street, 0, 1, along);
    Eigen::Isometry3d Tm;
    std::string name;
    if (kind == 0) {
      Tm = street_pose(town, street, 0, 1, along + 0.8, -1.7);
      name = "same-dir";
    } else if (kind == 1) {
      const Eigen::Vector3d p = Tq.translation();
      const double yaw = std::atan2(Tq.linear()(1, 0), Tq.linear()(0, 0));
      const Eigen::Vector2d fwd(std::cos(yaw), std::sin(yaw)), left(-std::sin(yaw), std::cos(yaw));
      const Eigen::Vector2d xy = p.head<2>() + 4.0 * left + 0.5 * fwd;  // the other lane, driving the other way
      Tm = ground_pose(town, xy.x(), xy.y(), yaw + M_PI);
      name = "opposite";
    } else {
      Tm = street_pose(town, street, 0, 1, along + 0.5, 1.0);
      name = "lane+3m";
    }
    Pair p;
    p.name = "sim " + name + " " + std::to_string(street);
    p.source = prepare_scan(simulate_scan(town, model, Tq, 100 + static_cast<std::uint64_t>(i), threads, 0), &model, prep);
    p.target = prepare_scan(simulate_scan(town, model, Tm, 200 + static_cast<std::uint64_t>(i), threads, 1), &model, prep);
    p.truth = Tm.inverse() * Tq;
    perturb.add(&p);
    pairs.push_back(std::move(p));
    prog.update(i + 1);
  }
  prog.finish();
  return pairs;
}

/// @brief Consecutive real KITTI 00 scans, when the data folder is present.
void add_kitti_pairs(const std::string& kitti_dir, const PrepareConfig& prep, Perturbations& perturb, std::vector<Pair>& pairs) {
  const LidarModel model = lidar_model_hdl64();
  // T_world_velo of KITTI 00; empty without the data folder
  const std::vector<Eigen::Isometry3d> velo_poses =
      read_kitti_lidar_poses(kitti_dir + "/poses/00.txt", kitti_dir + "/calib/Tr_velo_to_cam_00-02.txt").poses;
  for (const auto& fr : {std::pair<int, int>{94, 95}, std::pair<int, int>{198, 199}, std::pair<int, int>{0, 1}, std::pair<int, int>{3, 4}}) {
    char a[32], b[32];
    std::snprintf(a, sizeof a, "/seq00/%06d.bin", fr.first);
    std::snprintf(b, sizeof b, "/seq00/%06d.bin", fr.second);
    if (static_cast<std::size_t>(std::max(fr.first, fr.second)) >= velo_poses.size()) continue;
    const CloudFile read_a = read_kitti_bin(kitti_dir + a);
    const CloudFile read_b = read_a.ok ? read_kitti_bin(kitti_dir + b) : CloudFile{};
    if (!read_b.ok) continue;
    const PointCloud &ca = read_a.cloud, &cb = read_b.cloud;
    const Eigen::Isometry3d Ta = velo_poses[static_cast<std::size_t>(fr.first)], Tb = velo_poses[static_cast<std::size_t>(fr.second)];
    Pair p;
    p.name = "kitti 00 " + std::to_string(fr.second) + "->" + std::to_string(fr.first);
    p.source = prepare_scan(cb, &model, prep);
    p.target = prepare_scan(ca, &model, prep);
    p.truth = Ta.inverse() * Tb;
    perturb.add(&p);
    pairs.push_back(std::move(p));
  }
}

struct Method {
  std::string name;
  std::vector<double> ms, terr, rerr, cpu;
  int success = 0, runs = 0;
};

/// @brief The summary table of the methods that ran, and their figures in `j`.
tools::Table summarize_methods(const std::vector<const Method*>& methods, nlohmann::json& j) {
  tools::Table summary({"method", "runs", "success (<0.2 m, <1 deg)", "err m median", "err m p95", "err deg median", "ms median", "ms p95", "ms max",
                        "CPU ms median", "CPU ms p95"});
  for (const Method* m : methods) {
    if (m->runs == 0) continue;
    const auto ms = tools::summarize(m->ms), te = tools::summarize(m->terr), re = tools::summarize(m->rerr), cpu = tools::summarize(m->cpu);
    summary.add({m->name, std::to_string(m->runs), std::to_string(m->success) + "/" + std::to_string(m->runs), tools::fmt(te.median, 4),
                 tools::fmt(te.p95, 4), tools::fmt(re.median, 3), tools::fmt(ms.median, 1), tools::fmt(ms.p95, 1), tools::fmt(ms.max, 1),
                 tools::fmt(cpu.median, 1), tools::fmt(cpu.p95, 1)});
    j[m->name] = {{"runs", m->runs},
                  {"success", m->success},
                  {"translation_error_m", {{"median", te.median}, {"p95", te.p95}, {"max", te.max}}},
                  {"rotation_error_deg", {{"median", re.median}, {"p95", re.p95}, {"max", re.max}}},
                  {"ms", {{"median", ms.median}, {"p95", ms.p95}, {"max", ms.max}, {"mean", ms.mean}}},
                  {"cpu_ms", {{"median", cpu.median}, {"p95", cpu.p95}}}};
  }
  return summary;
}

struct Speedups {
  double ms = 0, cached_ms = 0, cpu_ms = 0;
};

/// @brief PCL's median over loopd's (0 when PCL did not run), also into `j`.
Speedups speedups_vs_pcl(const Method& full, const Method& cached, const Method& pcl, nlohmann::json& j) {
  Speedups s;
  if (pcl.runs > 0) {
    s.cpu_ms = tools::summarize(pcl.cpu).median / std::max(1e-9, tools::summarize(full.cpu).median);
    s.ms = tools::summarize(pcl.ms).median / std::max(1e-9, tools::summarize(full.ms).median);
    s.cached_ms = tools::summarize(pcl.ms).median / std::max(1e-9, tools::summarize(cached.ms).median);
  }
  j["speedup_vs_pcl_median"] = s.ms;
  j["speedup_cached_vs_pcl_median"] = s.cached_ms;
  j["speedup_cpu_vs_pcl_median"] = s.cpu_ms;
  return s;
}

}  // namespace

int run_bench_gicp(int argc, char** argv) {
  CLI::App app("loopd-bench gicp: loopd GICP vs PCL GICP (final error, ms)");
  int num_pairs = 6, perturbations = 2, threads = 2;
  bool json = false, no_pcl = false;
  PrepareConfig prep;
  GicpConfig gicp;
  double pcl_distance = 1.0;
  const char* data_env = std::getenv("LOOPD_DATA_DIR");
  std::string kitti_dir = std::string(data_env ? data_env : "../shared/data") + "/kitti";
  app.add_option("--pairs", num_pairs, "simulated revisit pairs")->capture_default_str();
  app.add_option("--perturbations", perturbations, "initial guesses per pair")->capture_default_str();
  app.add_option("--threads", threads, "threads for loopd GICP")->capture_default_str();
  app.add_option("--voxel", prep.voxel_size, "voxel size [m]")->capture_default_str();
  app.add_option("--k", gicp.k_neighbors, "covariance neighbours (both)")->capture_default_str();
  app.add_option("--max-source", gicp.max_source_points, "loopd: source points used in the optimisation (0 = all)")->capture_default_str();
  app.add_option("--pcl-distance", pcl_distance, "PCL max correspondence distance [m] (it has no schedule)")->capture_default_str();
  app.add_option("--kitti", kitti_dir, "KITTI folder (poses/, calib/, seq00/); skipped when absent")->capture_default_str();
  app.add_flag("--no-pcl", no_pcl, "skip the PCL peer");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  gicp.num_threads = threads;
  prep.num_threads = threads;
  prep.normal_k_neighbors = gicp.k_neighbors;

  // ---- pairs
  Perturbations perturb{perturbations};
  std::vector<Pair> pairs = simulated_pairs(num_pairs, threads, prep, perturb, !json);
  add_kitti_pairs(kitti_dir, prep, perturb, pairs);

  // ---- runs
  Method full, cached, pcl;
  full.name = "loopd align_gicp";
  cached.name = "loopd, cached normals";
  pcl.name = "PCL GICP";
  auto record = [](Method* m, const Eigen::Isometry3d& T, const Eigen::Isometry3d& truth, double ms, double cpu) {
    m->cpu.push_back(cpu);
    const double te = (T.translation() - truth.translation()).norm(), re = rot_err_deg(T, truth);
    m->ms.push_back(ms);
    m->terr.push_back(te);
    m->rerr.push_back(re);
    m->success += te < 0.2 && re < 1.0 ? 1 : 0;
    ++m->runs;
  };
  tools::Table per_pair({"pair", "points src/tgt", "init err m/deg", "loopd err m/deg", "loopd ms", "cached ms", "PCL err m/deg", "PCL ms"});
  std::int64_t total_runs = 0;
  for (const auto& p : pairs) total_runs += static_cast<std::int64_t>(p.inits.size());
  tools::Progress run_prog("aligning", total_runs, !json);
  std::int64_t done = 0;
  for (const auto& p : pairs) {
    const auto sn = p.source.unpacked_normals(), tn = p.target.unpacked_normals();
    for (const auto& init : p.inits) {
      Stopwatch sw;
      double c0 = process_cpu_ms();
      const GicpResult a = align_gicp(p.source.points, p.target.points, init, gicp);
      const double ms_a = sw.ms();
      record(&full, a.T_target_source, p.truth, ms_a, process_cpu_ms() - c0);
      sw.reset();
      c0 = process_cpu_ms();
      const GicpResult c = align_gicp(p.source.points, sn, p.target.points, tn, init, gicp);
      record(&cached, c.T_target_source, p.truth, sw.ms(), process_cpu_ms() - c0);
      std::string pcl_err = "-", pcl_ms = "-";
      if (!no_pcl) {
        const double c1 = process_cpu_ms();
        const bench::PclGicpResult q = bench::pcl_gicp_align(p.source.points, p.target.points, init, pcl_distance, 64, gicp.k_neighbors);
        if (q.available) {
          record(&pcl, q.T_target_source, p.truth, q.ms, process_cpu_ms() - c1);
          pcl_err = tools::fmt((q.T_target_source.translation() - p.truth.translation()).norm(), 3) + " / " +
                    tools::fmt(rot_err_deg(q.T_target_source, p.truth), 2);
          pcl_ms = tools::fmt(q.ms, 1);
        }
      }
      per_pair.add({p.name, std::to_string(p.source.points.size()) + "/" + std::to_string(p.target.points.size()),
                    tools::fmt((init.translation() - p.truth.translation()).norm(), 2) + " / " + tools::fmt(rot_err_deg(init, p.truth), 1),
                    tools::fmt(full.terr.back(), 3) + " / " + tools::fmt(full.rerr.back(), 2), tools::fmt(ms_a, 1), tools::fmt(cached.ms.back(), 1),
                    pcl_err, pcl_ms});
      run_prog.update(++done);
    }
  }
  run_prog.finish();

  nlohmann::json j;
  const tools::Table summary = summarize_methods({&full, &cached, &pcl}, j);
  const Speedups speedups = speedups_vs_pcl(full, cached, pcl, j);
  const double speedup = speedups.ms, speedup_cached = speedups.cached_ms, speedup_cpu = speedups.cpu_ms;
  j["pairs"] = pairs.size();
  j["voxel_size"] = prep.voxel_size;
  j["threads"] = threads;
  j["k_neighbors"] = gicp.k_neighbors;
  if (json) {
    tools::print_json_line(j);
    return 0;
  }
  std::cout << per_pair.str() << "\n" << summary.str();
  if (pcl.runs > 0)
    std::cout << "speed-up vs PCL (median ms): " << tools::fmt(speedup, 1) << "x, with cached normals " << tools::fmt(speedup_cached, 1)
              << "x; in CPU time " << tools::fmt(speedup_cpu, 1) << "x\n";
  std::cout << "voxel " << prep.voxel_size << " m, k " << gicp.k_neighbors << ", " << threads
            << " threads; machine load affects ms (2 shared cores)\n";
  return 0;
}
