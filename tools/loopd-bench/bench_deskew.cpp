// loopd-bench deskew: what deskew costs per scan and how far its variants lie from the truth, on the simulated scan
// of a drive that turns most during its sweep. The truth: every point moved with the ground-truth pose at its own time
// (a 2 kHz ground-truth stream, each point's own pose). The variants use a 10 Hz pose stream, as loopd gets it from
// odometry at the scan rate, with the sweep's poses at time_bins + 1 instants or each point's own.
#include <CLI/CLI.hpp>
#include <iostream>

#include "loopd/base/deskew.hpp"
#include "loopd/base/stopwatch.hpp"
#include "loopd/sim/drive.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

using namespace loopd;
using loopd::tools::fmt;

namespace {

/// The scan whose sweep turns most (ground truth from the sweep's start to its stamp).
int most_turning_scan(const Drive& drive) {
  int best = 1;
  double best_turn = -1.0;
  const double sweep_m = drive.config.speed / drive.config.rate_hz;
  for (int i = 1; i < static_cast<int>(drive.scans.size()); ++i) {
    const DriveScan& s = drive.scans[static_cast<std::size_t>(i)];
    const double turn = rotation_angle(drive.pose_at_distance(s.route_distance - sweep_m).inverse() * s.T_world_sensor);
    if (turn > best_turn) best = i, best_turn = turn;
  }
  return best;
}

/// Ground-truth poses every `period` [s] from `from` to `to` seconds around scan i's stamp.
std::vector<StampedPose> truth_stream(const Drive& drive, int i, double from, double to, double period) {
  const DriveScan& s = drive.scans[static_cast<std::size_t>(i)];
  std::vector<StampedPose> poses;
  for (double t = from; t <= to + 1e-9; t += period) {
    StampedPose p;
    p.utime = s.utime + static_cast<std::int64_t>(std::llround(t * 1e6));
    p.T_world_sensor = drive.pose_at_distance(s.route_distance + drive.config.speed * static_cast<double>(p.utime - s.utime) / 1e6);
    poses.push_back(p);
  }
  return poses;
}

struct DeskewRow {
  std::string name;
  tools::Summary ms;
  double max_error = 0, mean_error = 0;
};

}  // namespace

int run_bench_deskew(int argc, char** argv) {
  CLI::App app("loopd-bench deskew: ms per scan and error against the truth per deskew variant", "loopd-bench deskew");
  DriveConfig cfg;
  cfg.route = "block";
  cfg.num_scans = 300;
  int repeats = 20;
  bool json = false;
  app.add_option("--sensor", cfg.sensor, "lidar model")->capture_default_str();
  app.add_option("--route", cfg.route, "route (town or block)")->capture_default_str();
  app.add_option("--scans", cfg.num_scans, "scans of the drive searched for the sharpest turn")->capture_default_str();
  app.add_option("--speed", cfg.speed, "[m/s]")->capture_default_str();
  app.add_option("--seed", cfg.seed, "town seed")->capture_default_str();
  app.add_option("--repeats", repeats, "timed runs per variant")->capture_default_str();
  app.add_flag("--json", json, "one JSON object as the last stdout line");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;
  const Drive drive = make_drive(cfg);
  if (!drive.error.empty() || cfg.num_scans < 2 || repeats < 1) {
    std::cerr << "loopd-bench deskew: " << (drive.error.empty() ? "need --scans >= 2 and --repeats >= 1" : drive.error) << "\n";
    return 1;
  }
  const int i = most_turning_scan(drive);
  const PointCloud raw = drive.simulate(i, 0);
  const std::int64_t utime = drive.scans[static_cast<std::size_t>(i)].utime;
  DeskewConfig exact;
  exact.time_bins = 0;
  PointCloud truth = raw;
  const DeskewResult moved = deskew(exact, truth_stream(drive, i, -0.2, 0.1, 0.0005), utime, &truth);

  const auto stream = truth_stream(drive, i, -0.3, 0.0, 1.0 / cfg.rate_hz);
  // As a Velodyne gives them: the lasers of one column fire a few microseconds apart, so no two points share a time.
  PointCloud distinct = raw;
  for (std::size_t k = 0; k < distinct.size(); ++k)
    distinct.time[k] -= 2.3e-6f * static_cast<float>(distinct.has_rings() ? distinct.ring[k] : k % 64);
  std::vector<DeskewRow> rows;
  const auto add_row = [&](const std::string& name, const PointCloud& input, int bins, int runs) {
    DeskewConfig c;
    c.time_bins = bins;
    std::vector<double> ms;
    PointCloud out = input;
    for (int r = 0; r < runs; ++r) {
      out = input;
      Stopwatch w;
      if (bins >= 0) deskew(c, stream, utime, &out);
      ms.push_back(w.ms());
    }
    DeskewRow row{name, tools::summarize(ms)};
    for (std::size_t k = 0; k < out.size(); ++k) {
      const double e = static_cast<double>((out.points[k] - truth.points[k]).norm());
      row.max_error = std::max(row.max_error, e);
      row.mean_error += e / static_cast<double>(out.size());
    }
    rows.push_back(row);
  };
  add_row("not deskewed", raw, -1, 1);
  add_row("each point's own pose (one per column)", raw, 0, repeats);
  add_row("each point's own pose (distinct times)", distinct, 0, repeats);
  for (const int bins : {16, 64, 256}) add_row(std::to_string(bins) + " bins (distinct times)", distinct, bins, repeats);
  std::cout << "scan " << i << " of a " << cfg.sensor << " " << cfg.route << " drive at " << fmt(cfg.speed, 1) << " m/s: " << raw.size()
            << " points, sweep " << fmt(moved.sweep, 3) << " s, turning "
            << fmt(rotation_angle(stream[2].T_world_sensor.inverse() * stream[3].T_world_sensor) * 57.29578, 2)
            << " deg in it; deskew moves points by up to " << fmt(moved.max_correction, 3) << " m\n";
  tools::Table table({"variant (10 Hz poses)", "median ms", "p95 ms", "max error vs truth [m]", "mean error [m]"});
  nlohmann::json variants = nlohmann::json::array();
  for (const DeskewRow& r : rows) {
    table.add({r.name, fmt(r.ms.median, 3), fmt(r.ms.p95, 3), fmt(r.max_error, 4), fmt(r.mean_error, 5)});
    variants.push_back(
        {{"variant", r.name}, {"median_ms", r.ms.median}, {"p95_ms", r.ms.p95}, {"max_error", r.max_error}, {"mean_error", r.mean_error}});
  }
  std::cout << table.str();
  if (json) tools::print_json_line({{"scan", i}, {"points", raw.size()}, {"max_correction", moved.max_correction}, {"variants", variants}});
  return 0;
}
