// loopd-bench register: loopd's plane-based 4PCS (Vlaminck 2019, Sec. 4.2) vs PCL's KFPCSInitialAlignment and
// FPCSInitialAlignment on the same pairs, no initial guess. Per method: success rate (rotation error < 5 deg and
// translation error < 0.5 m) and median / p95 ms.
//
// Pairs: simulated HDL-64E revisits of the procedural town (query on visit 1 with moved parked cars, 2 m from the
// match, heading turned by 0/45/90/135/180 deg in turn), plus real KITTI 00 pairs (consecutive scans, query turned
// by 0/90/180 deg about its z axis) and the real KITTI 08 revisit (frame 1500 against 720, turned 148 deg; truth
// from the data README) when the data folder is present. The real pairs are also summarised on their own.
//
// How the peers are tuned (pcl_peers_registration.cpp): the same delta (0.5 m, absolute, not density-normalised),
// approximate overlap 0.7 (same-place pairs), one thread like loopd, at most 2 s per pair. Their input is
// downsampled (PCL's pair search is brute force over all target point pairs): FPCS gets a 1.5 m voxel grid of each
// scan (about 1-2k points) and scores 500 source samples; KFPCS gets a 2.5 m voxel grid as its sparse "keypoints".
// PCL seeds std::rand with time() inside align(), so its figures vary run to run (no seed can be fixed). loopd's
// time is align_four_pcs on prepared scans (segmentation is cached per keyframe); preparation is reported apart.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>
#include <sstream>

#include "loopd/base/cloud_ops.hpp"
#include "loopd/base/lidar_model.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/io/kitti_files.hpp"
#include "loopd/io/cloud_file.hpp"
#include "loopd/pipeline/register_scans.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"
#include "pcl_peers_registration.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;

namespace {

constexpr double kDeg = M_PI / 180.0;

struct RegisterPair {
  std::string name;
  PointCloud query, match;  // raw scans
  Eigen::Isometry3d truth;  // T_match_query
};

struct MethodStats {
  std::string name;
  int success = 0, runs = 0;
  std::vector<double> ms, cpu_ms, rot_err, trans_err;
};

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

void record(MethodStats* s, const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth, bool ok, double ms, double cpu) {
  const Eigen::Isometry3d e = truth.inverse() * estimate;
  const double rot = rotation_angle(e) / kDeg, trans = e.translation().norm();
  ++s->runs;
  if (ok && rot < 5.0 && trans < 0.5) ++s->success;
  s->ms.push_back(ms);
  s->cpu_ms.push_back(cpu);
  s->rot_err.push_back(rot);
  s->trans_err.push_back(trans);
}

std::vector<RegisterPair> simulated_pairs(int n) {
  std::vector<RegisterPair> pairs;
  const Town town = make_town(1);
  const LidarModel model = lidar_model_hdl64();
  const double yaws[] = {0, 45, 90, 135, 180};
  for (int k = 0; k < n; ++k) {
    const int place = k / 5 % 4, yaw_i = k % 5;
    const Eigen::Isometry3d A = street_pose(town, place, 1 + k / 20, place % 2, 25.0);
    const double yaw_a = std::atan2(A.linear()(1, 0), A.linear()(0, 0));
    const Eigen::Isometry3d B = ground_pose(town, A.translation().x() + 1.41, A.translation().y() + 1.41, yaw_a + yaws[yaw_i] * kDeg);
    RegisterPair p;
    p.name = "sim place " + std::to_string(place) + " yaw " + std::to_string(static_cast<int>(yaws[yaw_i]));
    p.match = simulate_scan(town, model, A, 7 + static_cast<std::uint64_t>(k), 1, 0);
    p.query = simulate_scan(town, model, B, 1000 + static_cast<std::uint64_t>(k), 1, 1);
    p.truth = A.inverse() * B;
    pairs.push_back(std::move(p));
  }
  return pairs;
}

std::vector<RegisterPair> kitti_pairs(const std::string& dir) {
  std::vector<RegisterPair> pairs;
  const int ids[][2] = {{1, 0}, {3, 2}, {95, 94}, {199, 198}};
  const double yaws[] = {0, 90, 180};
  const TrajectoryFile kitti = read_kitti_lidar_poses(dir + "/poses/00.txt", dir + "/calib/Tr_velo_to_cam_00-02.txt");
  if (!kitti.ok) return pairs;
  const std::vector<Eigen::Isometry3d>& velo_poses = kitti.poses;  // T_world_velo (data README)
  int k = 0;
  for (const auto& id : ids) {
    if (static_cast<std::size_t>(std::max(id[0], id[1])) >= velo_poses.size()) continue;
    const Eigen::Isometry3d Tq = velo_poses[static_cast<std::size_t>(id[0])], Tm = velo_poses[static_cast<std::size_t>(id[1])];
    char nq[64], nm[64];
    std::snprintf(nq, sizeof nq, "/seq00/%06d.bin", id[0]);
    std::snprintf(nm, sizeof nm, "/seq00/%06d.bin", id[1]);
    const CloudFile read_q = read_kitti_bin(dir + nq);
    const CloudFile read_m = read_q.ok ? read_kitti_bin(dir + nm) : CloudFile{};
    if (!read_m.ok) continue;
    const PointCloud &q = read_q.cloud, &m = read_m.cloud;
    const double yaw = yaws[k++ % 3];
    const Eigen::Isometry3d R = make_isometry(0, 0, 0, yaw * kDeg);
    RegisterPair p;
    p.name = "kitti " + std::to_string(id[0]) + "->" + std::to_string(id[1]) + " yaw " + std::to_string(static_cast<int>(yaw));
    p.query = transform(q, R);
    p.match = std::move(m);
    p.truth = Tm.inverse() * Tq * R.inverse();
    pairs.push_back(std::move(p));
  }
  return pairs;
}

// The real revisit (data README): KITTI 08 frame 1500 seen from frame 720, about 2.5 m apart, heading turned about
// 148 deg; the truth is the README's T_match_query. Empty when absent or unreadable.
std::vector<RegisterPair> kitti_revisit(const std::string& dir) {
  std::ifstream in(dir + "/seq08/relative_1500_720.txt");
  double m[16];  // row-major, after the '#' comment lines
  int have = 0;
  for (std::string line; have < 16 && std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream row(line);
    for (int c = 0; c < 4 && row >> m[have]; ++c) ++have;
  }
  const CloudFile query = have == 16 ? read_kitti_bin(dir + "/seq08/001500.bin") : CloudFile{};
  const CloudFile match = query.ok ? read_kitti_bin(dir + "/seq08/000720.bin") : CloudFile{};
  if (!match.ok) return {};
  RegisterPair p;
  p.name = "kitti 08 1500->720 (revisit)";
  p.query = query.cloud;
  p.match = match.cloud;
  p.truth = from_row_major(m);
  std::vector<RegisterPair> pairs;
  pairs.push_back(std::move(p));
  return pairs;
}

double success_rate(const MethodStats& s) { return s.runs > 0 ? static_cast<double>(s.success) / s.runs : 0.0; }

// One table row per method: success, time and median errors.
tools::Table method_table(const std::vector<const MethodStats*>& methods) {
  tools::Table t({"method", "pairs", "success", "rate", "median ms", "p95 ms", "median cpu ms", "median rot err deg", "median trans err m"});
  for (const MethodStats* s : methods) {
    const auto ms = tools::summarize(s->ms), cpu = tools::summarize(s->cpu_ms);
    const auto rot = tools::summarize(s->rot_err), tr = tools::summarize(s->trans_err);
    t.add({s->name, std::to_string(s->runs), std::to_string(s->success), tools::fmt(success_rate(*s), 2), tools::fmt(ms.median, 1),
           tools::fmt(ms.p95, 1), tools::fmt(cpu.median, 1), tools::fmt(rot.median, 2), tools::fmt(tr.median, 2)});
  }
  return t;
}

// The same per method for --json.
nlohmann::json method_json(const std::vector<const MethodStats*>& methods) {
  nlohmann::json out = nlohmann::json::array();
  for (const MethodStats* s : methods) {
    const auto ms = tools::summarize(s->ms), cpu = tools::summarize(s->cpu_ms);
    out.push_back({{"name", s->name},
                   {"runs", s->runs},
                   {"success", s->success},
                   {"success_rate", success_rate(*s)},
                   {"median_ms", ms.median},
                   {"p95_ms", ms.p95},
                   {"median_cpu_ms", cpu.median},
                   {"p95_cpu_ms", cpu.p95}});
  }
  return out;
}

std::vector<Eigen::Vector3f> grid(const PointCloud& scan, double voxel, double min_range, double max_range) {
  return voxel_downsample(crop_range(remove_non_finite(scan), min_range, max_range), voxel).points;
}

}  // namespace

int run_bench_register(int argc, char** argv) {
  CLI::App app("loopd-bench register: loopd 4PCS vs PCL KFPCS / FPCS (success rate, ms)");
  int num_pairs = 10, pcl_seconds = 2;
  bool json = false, no_pcl = false, no_kitti = false;
  ScanRegistrationConfig cfg;
  app.add_option("--pairs", num_pairs, "simulated HDL-64E pairs")->capture_default_str();
  app.add_option("--threads", cfg.four_pcs.num_threads, "loopd threads")->capture_default_str();
  app.add_option("--pcl-seconds", pcl_seconds, "time cap per pair for each PCL peer [s]")->capture_default_str();
  app.add_flag("--no-pcl", no_pcl, "skip the PCL peers");
  app.add_flag("--no-kitti", no_kitti, "skip the real KITTI pairs");
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  const char* data_env = std::getenv("LOOPD_DATA_DIR");
  const std::string data_dir = data_env != nullptr ? data_env : "../shared/data";

  std::vector<RegisterPair> pairs = simulated_pairs(num_pairs);
  std::vector<RegisterPair> real;
  if (!no_kitti) {
    real = kitti_pairs(data_dir + "/kitti");
    for (auto& p : kitti_revisit(data_dir + "/kitti")) real.push_back(std::move(p));
  }
  const std::size_t num_sim = pairs.size();
  for (auto& p : real) pairs.push_back(std::move(p));

  const LidarModel hdl64 = lidar_model_hdl64();
  MethodStats loopd_stats, loopd_real_stats, kfpcs_stats, fpcs_stats;
  loopd_stats.name = "loopd 4PCS (plane bases)";
  loopd_real_stats.name = "loopd 4PCS, real pairs only";
  kfpcs_stats.name = "PCL KFPCS";
  fpcs_stats.name = "PCL FPCS";
  std::vector<double> prep_ms, lcp;
  std::vector<std::string> real_lines;  // per real pair: time and errors
  bool pcl_available = false;
  bench::PclFpcsConfig pcl_cfg;
  pcl_cfg.max_seconds = pcl_seconds;
  tools::Progress progress("register", static_cast<std::int64_t>(pairs.size()), !json);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const RegisterPair& p = pairs[i];
    const LidarModel* model = i < num_sim ? &hdl64 : nullptr;  // KITTI: rings from binned elevations
    const PreparedScan q = prepare_scan(p.query, model, cfg.prepare);
    const PreparedScan m = prepare_scan(p.match, model, cfg.prepare);
    prep_ms.push_back(0.5 * (q.ms_total + m.ms_total));
    const double c0 = thread_cpu_ms();
    const FourPcsResult r = align_four_pcs(q.points, q.segmentation, m.points, m.segmentation, cfg.four_pcs);
    const double cpu_ms = thread_cpu_ms() - c0;
    record(&loopd_stats, r.T_target_source, p.truth, r.success, r.ms, cpu_ms);
    if (i >= num_sim) {
      record(&loopd_real_stats, r.T_target_source, p.truth, r.success, r.ms, cpu_ms);
      real_lines.push_back(p.name + ": " + tools::fmt(r.ms, 1) + " ms, rotation error " + tools::fmt(loopd_real_stats.rot_err.back(), 2) +
                           " deg, translation error " + tools::fmt(loopd_real_stats.trans_err.back(), 3) + " m");
    }
    lcp.push_back(r.lcp_fraction);
    if (!no_pcl) {
      const double lo = cfg.prepare.min_range, hi = cfg.prepare.max_range;
      const auto fq = grid(p.query, 1.5, lo, hi), fm = grid(p.match, 1.5, lo, hi);
      const auto kq = grid(p.query, 2.5, lo, hi), km = grid(p.match, 2.5, lo, hi);
      const bench::PclFpcsResult k = bench::pcl_fpcs_align(bench::PclFpcsVariant::kKfpcs, kq, km, pcl_cfg);
      const bench::PclFpcsResult f = bench::pcl_fpcs_align(bench::PclFpcsVariant::kFpcs, fq, fm, pcl_cfg);
      pcl_available = k.available;
      if (k.available) record(&kfpcs_stats, k.T_target_source, p.truth, true, k.ms, k.cpu_ms);
      if (f.available) record(&fpcs_stats, f.T_target_source, p.truth, true, f.ms, f.cpu_ms);
    }
    progress.update(static_cast<std::int64_t>(i + 1));
  }
  progress.finish();

  std::vector<const MethodStats*> methods = {&loopd_stats};
  if (loopd_real_stats.runs > 0) methods.push_back(&loopd_real_stats);
  if (pcl_available) {
    methods.push_back(&kfpcs_stats);
    methods.push_back(&fpcs_stats);
  }
  tools::Table t = method_table(methods);
  nlohmann::json j;
  j["pairs_simulated"] = num_sim;
  j["pairs_kitti"] = pairs.size() - num_sim;
  j["methods"] = method_json(methods);
  const auto prep = tools::summarize(prep_ms);
  j["loopd_prepare_median_ms"] = prep.median;
  j["loopd_lcp_median"] = tools::summarize(lcp).median;
  if (json) {
    tools::print_json_line(j);
    return 0;
  }
  std::cout << t.str();
  std::cout << "pairs: " << num_sim << " simulated HDL-64E revisits + " << pairs.size() - num_sim
            << " real KITTI pairs (00: consecutive scans turned 0/90/180 deg; 08: a revisit turned 148 deg); success = rot err < 5 deg and trans err "
               "< 0.5 m; no initial guess.\n"
            << "loopd prepare (segmentation + voxel grid, cached per keyframe): median " << tools::fmt(prep.median, 1) << " ms per scan.\n";
  for (const std::string& line : real_lines) std::cout << "  " << line << "\n";
  if (!pcl_available && !no_pcl) std::cout << "(PCL peers not built: LOOPD_WITH_PCL is off)\n";
  return 0;
}
