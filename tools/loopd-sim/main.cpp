// loopd-sim: writes a simulated lidar drive through the procedural town as an lcm-logger file.
// Channels: LIDAR_SCAN (point_cloud_t, with per-point times), ODOMETRY_POSE and GROUND_TRUTH_POSE (pose_t, the true
// pose at the scan's utime, the end of its sweep); event timestamps = utime.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <array>
#include <iostream>
#include <optional>
#include <thread>

#include "loopd/base/stopwatch.hpp"
#include "loopd/sim/drive.hpp"
#include "loopd/sim/gyro_sim.hpp"
#include "loopd/sim/movers.hpp"
#include "loopd/sim/odometry_stream.hpp"
#include "lcm_log.hpp"
#include "message_convert.hpp"
#include "tool_output.hpp"
#include "exit_codes.hpp"

namespace {

using loopd::tools::fmt;

int list_sensors(bool json) {
  loopd::tools::Table table({"name", "rings", "vertical [deg]", "columns", "az step [deg]", "range [m]", "noise [m]", "dropout"});
  nlohmann::json arr = nlohmann::json::array();
  std::vector<std::string> names = loopd::lidar_model_names();
  for (const auto& n : loopd::lidar_pattern_model_names()) names.push_back(n);
  for (const auto& name : names) {
    const auto m = *loopd::lidar_model_from_name(name);
    table.add({m.name, std::to_string(m.num_rings), fmt(m.vertical_angles_deg.front(), 2) + ".." + fmt(m.vertical_angles_deg.back(), 2),
               std::to_string(m.azimuth_steps), fmt(m.azimuth_step_deg(), 4), fmt(m.min_range, 1) + ".." + fmt(m.max_range, 0),
               fmt(m.range_noise_sigma, 3), fmt(m.dropout_rate, 3)});
    arr.push_back({{"name", m.name},
                   {"num_rings", m.num_rings},
                   {"azimuth_steps", m.azimuth_steps},
                   {"min_range", m.min_range},
                   {"max_range", m.max_range},
                   {"vertical_angles_deg", m.vertical_angles_deg}});
  }
  std::cout << table.str();
  if (json) loopd::tools::print_json_line({{"sensors", arr}});
  return 0;
}

/// Sensor effects: each on by default, each with a flag that turns it off.
void add_effect_options(CLI::App& app, loopd::SensorEffects* fx) {
  auto off = [](bool* on) { return [on](std::int64_t) { *on = false; }; };
  app.add_flag_function("--no-motion-skew", off(&fx->motion_skew),
                        "instantaneous scans: without it each column is measured at its own time of the sweep (1/rate s, clockwise from behind; "
                        "the scan is stamped at the sweep's end) from the pose at that time, not motion-compensated");
  app.add_flag_function("--no-point-times", off(&fx->point_times),
                        "no per-point times (point_cloud_t.num_point_times = 0); with them, time_offset is each point's time relative to "
                        "utime (-1/rate .. 0 s; 0 with --no-motion-skew)");
  app.add_flag_function("--no-dropouts", off(&fx->dropouts),
                        "only the lidar model's own dropouts: without it returns are also lost at --dropout-rate, more far away, at "
                        "grazing incidence and on dark surfaces");
  app.add_option("--dropout-rate", fx->dropout_rate, "rate of lost returns on near, head-on, bright surfaces (x3 at max range, x3 grazing, x2 black)")
      ->capture_default_str();
  app.add_flag_function("--no-vegetation", off(&fx->vegetation),
                        "no bushes and solid tree crowns: without it bushes line some sidewalks and foliage is porous, its points "
                        "different on every scan (seeded by --seed and the scan)");
  app.add_option("--foliage-density", fx->foliage_density,
                 "foliage extinction [1/m]: a ray returns within d m of foliage with probability 1-exp(-density d)")
      ->capture_default_str();
}

/// Drive options: route, seed, session, speed and the odometry's drift; --odometry-reset-at into *reset_at.
void add_drive_options(CLI::App& app, loopd::DriveConfig* cfg, std::optional<int>* reset_at) {
  app.add_option("--sensor", cfg->sensor, "lidar model (see --list-sensors)")->capture_default_str();
  app.add_option("--scans", cfg->num_scans, "number of scans")->capture_default_str();
  app.add_option("--seed", cfg->seed, "town / noise / drift seed")->capture_default_str();
  app.add_option("--route", cfg->route,
                 "route: town (three visits: block loop, long loop with lane offset, opposite direction), block (the block loop, lap after "
                 "lap), ring (the streets two blocks in from the town's edges, ~1.5 km a round, round after round: first revisit after "
                 "a whole round, for large drift) or mine (an underground roadway grid: a cell loop, a long loop, the cell again, ~1.1 km "
                 "a lap, on the roadway centre line with 3 m corners; featureless tunnels between distinctive junctions)")
      ->capture_default_str();
  app.add_option("--speed", cfg->speed, "vehicle speed [m/s]")->capture_default_str();
  app.add_option("--rate", cfg->rate_hz, "scan rate [Hz]")->capture_default_str();
  app.add_option("--heading-bias", cfg->heading_bias_deg_per_100m, "odometry heading bias [deg/100 m]")->capture_default_str();
  app.add_option("--scale-bias", cfg->scale_bias, "odometry scale bias (fraction)")->capture_default_str();
  app.add_option("--yaw-walk", cfg->yaw_random_walk_deg, "odometry yaw random walk [deg/step]")->capture_default_str();
  app.add_option("--translation-noise", cfg->translation_noise, "odometry translation noise [m/step]")->capture_default_str();
  app.add_option("--burst-probability", cfg->burst_probability, "chance per step of a degraded odometry stretch")->capture_default_str();
  app.add_option("--session", cfg->session,
                 "session K in [1, 1000]: 1 = the drive of --seed; K >= 2 = the same town (same static geometry) on another day: "
                 "even K drive the route in the opposite direction (right-hand lane), odd K in the same; the start is lap length * "
                 "hash(seed, K, attempt) into the lap for the first attempt whose start is > 50 m from session 1's or heads > 90 deg "
                 "away; own odometry noise and drift (seeded by seed, K), odometry starting at identity (ground truth in session 1's "
                 "world frame), own scan noise and parked-car states; scans start K - 1 days after session 1's")
      ->capture_default_str();
  app.add_flag("--same-day", cfg->same_day,
               "session K >= 2 starts at session 1's scan times, not K - 1 days later (two vehicles' logs of the same hour)");
  app.add_option("--start-utime", cfg->start_utime, "[us since the epoch] session 1's first scan")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{4102444800000000}))
      ->capture_default_str();
  app.add_option("--odometry-reset-at", *reset_at,
                 "scan N in [1, scans) where the odometry restarts (a restarted odometry process): T_odom_sensor(N) = identity, drift "
                 "from there; ground truth unchanged");
}

std::string effects_text(const loopd::SensorEffects& fx) {
  std::string s;
  auto add = [&s](bool on, const std::string& name) {
    if (on) s += (s.empty() ? "" : ", ") + name;
  };
  add(fx.motion_skew, "motion skew");
  add(fx.point_times, "point times");
  add(fx.dropouts, "dropouts " + fmt(fx.dropout_rate, 3));
  add(fx.vegetation, "vegetation");
  return s.empty() ? "none" : s;
}

/// What the run measured, for the summary.
struct RunFigures {
  double seconds = 0.0;
  int threads = 0;
  std::vector<double> points_per_scan, ms_cast, ms_write;
};

/// The --json line. fig: points per scan mean / min / max, cast median / p95, write median [ms], odometry end error [m], bytes.
void print_summary_json(const loopd::Drive& drive, const std::string& out, const RunFigures& run, const std::array<double, 8>& fig, int revisits) {
  const loopd::DriveConfig& cfg = drive.config;
  const auto& fx = cfg.effects;
  loopd::tools::print_json_line({{"out", out},
                                 {"sensor", drive.model.name},
                                 {"effects",
                                  {{"motion_skew", fx.motion_skew},
                                   {"point_times", fx.point_times},
                                   {"dropouts", fx.dropouts},
                                   {"dropout_rate", fx.dropout_rate},
                                   {"vegetation", fx.vegetation},
                                   {"foliage_density", fx.foliage_density}}},
                                 {"scans", drive.scans.size()},
                                 {"seed", cfg.seed},
                                 {"route", cfg.route},
                                 {"session", cfg.session},
                                 {"reversed", drive.reversed},
                                 {"start_offset_m", drive.start_offset},
                                 {"start_utime", drive.scans.front().utime},
                                 {"odometry_reset_at", cfg.odometry_reset_at ? nlohmann::json(*cfg.odometry_reset_at) : nlohmann::json(nullptr)},
                                 {"points_per_scan_mean", fig[0]},
                                 {"points_per_scan_min", fig[1]},
                                 {"points_per_scan_max", fig[2]},
                                 {"route_length_m", drive.route_length()},
                                 {"lap_length_m", drive.lap_length},
                                 {"visits", drive.num_visits()},
                                 {"revisits", revisits},
                                 {"odometry_end_error_m", fig[6]},
                                 {"cast_ms_median", fig[3]},
                                 {"cast_ms_p95", fig[4]},
                                 {"write_ms_median", fig[5]},
                                 {"threads", run.threads},
                                 {"bytes", static_cast<std::uint64_t>(fig[7])},
                                 {"seconds", run.seconds}});
}

/// Writes every scan with its odometry and ground truth: scan i+1 is ray-cast on a worker while scan i is encoded and
/// written (same results as serial: each scan only depends on its index). False when a write failed.
/// What is written besides the scans and the scan-rate poses: a gyro on IMU, odometry poses between the scans.
struct Streams {
  loopd::GyroSimConfig gyro{0.0};  // no gyro unless --imu-rate
  double pose_rate_hz = 0.0;       ///< odometry poses at this rate (0: only at the scans)
};

bool write_drive(const loopd::Drive& drive, const Streams& streams, loopd::LogWriter* writer, bool quiet, RunFigures* run) {
  const int n = static_cast<int>(drive.scans.size());
  loopd::tools::Progress progress("loopd-sim", n, !quiet);
  std::vector<double>&points_per_scan = run->points_per_scan, &ms_cast = run->ms_cast, &ms_write = run->ms_write;
  const int nt = run->threads;
  points_per_scan.reserve(static_cast<std::size_t>(n));
  bool ok = true;

  loopd::PointCloud current, next;
  std::int64_t imu_seq = 0;
  loopd::Stopwatch sw;
  current = drive.simulate(0, nt);
  ms_cast.push_back(sw.ms());
  for (int i = 0; i < n && ok; ++i) {
    double cast_ms = 0.0;
    std::thread worker;
    if (i + 1 < n) {
      worker = std::thread([&, i] {
        loopd::Stopwatch w;
        next = drive.simulate(i + 1, nt);
        cast_ms = w.ms();
      });
    }
    loopd::Stopwatch ws;
    const auto& sc = drive.scans[static_cast<std::size_t>(i)];
    // Time order: the gyro's samples and the odometry's poses of this scan's sweep come before its stamp.
    std::vector<std::pair<std::int64_t, loopd::imu_t>> imu;
    for (const loopd::ImuSample& g : loopd::simulate_gyro(drive, streams.gyro, i)) imu.emplace_back(g.utime, loopd::to_message(g, imu_seq++));
    const std::vector<loopd::StampedPose> between = loopd::odometry_between_scans(drive, i, streams.pose_rate_hz);
    std::size_t gi = 0, pi = 0;
    while (ok && (gi < imu.size() || pi < between.size())) {
      if (pi == between.size() || (gi < imu.size() && imu[gi].first <= between[pi].utime)) {
        ok = writer->write_message(loopd::channels::kImu, imu[gi].first, imu[gi].second);
        ++gi;
      } else {
        ok = writer->write_message(loopd::channels::kPose, between[pi].utime, loopd::to_message(between[pi], i));
        ++pi;
      }
    }
    loopd::StampedPose gt;
    gt.utime = sc.utime;
    gt.T_world_sensor = sc.T_world_sensor;
    ok = writer->write_message(loopd::channels::kPose, sc.utime, loopd::to_message(sc.odometry, i)) &&
         writer->write_message(loopd::channels::kGroundTruth, sc.utime, loopd::to_message(gt, i)) &&
         writer->write_message(loopd::channels::kScan, sc.utime, loopd::to_message(current, sc.utime, i, "lidar"));
    points_per_scan.push_back(static_cast<double>(current.size()));
    ms_write.push_back(ws.ms());
    if (worker.joinable()) worker.join();
    if (i + 1 < n) {
      ms_cast.push_back(cast_ms);
      std::swap(current, next);
    }
    progress.update(i + 1);
  }
  progress.finish();
  return ok;
}

/// The summary table, and with `json` one JSON object as the last line.
void print_summary(const loopd::Drive& drive, const std::string& out, bool json, const RunFigures& run) {
  const loopd::DriveConfig& cfg = drive.config;
  const int n = static_cast<int>(drive.scans.size());
  const auto pts = loopd::tools::summarize(run.points_per_scan);
  const auto cast = loopd::tools::summarize(run.ms_cast);
  const auto wr = loopd::tools::summarize(run.ms_write);
  const double min_pts = run.points_per_scan.empty() ? 0.0 : *std::min_element(run.points_per_scan.begin(), run.points_per_scan.end());
  const auto& last = drive.scans.back();
  const double end_error = (last.odometry.T_world_sensor.translation() - last.T_world_sensor.translation()).norm();
  const int revisits = drive.count_revisits(1.0, 100);
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(out, ec);
  const std::string reset = cfg.odometry_reset_at ? "at scan " + std::to_string(*cfg.odometry_reset_at) : "none";

  loopd::tools::Table table({"quantity", "value"});
  table.add({"sensor", drive.model.name});
  table.add({"sensor effects", effects_text(cfg.effects)});
  table.add(
      {"session", std::to_string(cfg.session) + (drive.reversed ? " (reversed)" : "") + ", start " + fmt(drive.start_offset, 1) + " m into the lap"});
  table.add({"odometry reset", reset});
  table.add({"scans", std::to_string(n)});
  table.add({"points/scan (mean / min / max)", fmt(pts.mean, 0) + " / " + fmt(min_pts, 0) + " / " + fmt(pts.max, 0)});
  table.add({"route length [m]", fmt(drive.route_length(), 1)});
  table.add({"lap length [m]", fmt(drive.lap_length, 1)});
  table.add({"visits", std::to_string(drive.num_visits())});
  table.add({"revisited scans (GT < 1 m, > 100 scans apart)", std::to_string(revisits)});
  table.add({"odometry end error [m]", fmt(end_error, 2)});
  table.add({"ray cast ms/scan (median / p95)", fmt(cast.median, 1) + " / " + fmt(cast.p95, 1)});
  table.add({"encode+write ms/scan (median)", fmt(wr.median, 1)});
  table.add({"threads", std::to_string(run.threads)});
  table.add({"file size [MB]", fmt(static_cast<double>(bytes) / 1e6, 1)});
  table.add({"seconds", fmt(run.seconds, 2)});
  std::cout << table.str();
  if (json)
    print_summary_json(drive, out, run, {pts.mean, min_pts, pts.max, cast.median, cast.p95, wr.median, end_error, static_cast<double>(bytes)},
                       revisits);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-sim: simulated lidar drive through a procedural town (or mine), written as an lcm-logger file"};
  loopd::DriveConfig cfg;
  std::optional<int> reset_at;
  std::string out, movers_out;
  bool json = false, list = false, quiet = false;
  int threads = 0;
  app.add_option("--out", out, "output lcm-logger file");
  app.add_option("--movers-out", movers_out,
                 "also write the boxes of every state of the movable objects that change during the drive (loopd-movers JSON)");
  add_drive_options(app, &cfg, &reset_at);
  add_effect_options(app, &cfg.effects);
  Streams streams;
  app.add_option("--imu-rate", streams.gyro.rate_hz,
                 "gyro samples per second on IMU (imu_t, in the lidar's frame: the true turn rate plus --gyro-noise and a constant "
                 "bias within --gyro-bias per axis); 0 = none")
      ->capture_default_str();
  app.add_option("--gyro-noise", streams.gyro.noise_deg_s, "[deg/s] gyro white noise per sample and axis")->capture_default_str();
  app.add_option("--gyro-bias", streams.gyro.bias_deg_s, "[deg/s] largest constant gyro bias per axis")->capture_default_str();
  app.add_option("--pose-rate", streams.pose_rate_hz,
                 "odometry poses per second (above --rate: poses between the scans follow the true path, the step's drift spread "
                 "evenly; 0 = at the scans only)")
      ->capture_default_str();
  app.add_option("--threads", threads, "ray-casting threads (0 = all cores)")->capture_default_str();
  app.add_flag("--list-sensors", list, "list the lidar models and exit");
  app.add_flag("--json", json, "print one JSON object as the last line");
  app.add_flag("--quiet", quiet, "no progress bar");
  if (auto rc = loopd::tools::parse_command_line(app, argc, argv)) return *rc;

  if (list) return list_sensors(json);
  if (out.empty()) {
    std::cerr << "loopd-sim: --out is required (or --list-sensors)\n";
    return 2;
  }
  cfg.odometry_reset_at = reset_at;
  if (auto err = cfg.validate()) {
    std::cerr << "loopd-sim: " << *err << "\n";
    return 2;
  }
  if (auto err = streams.gyro.validate()) {
    std::cerr << "loopd-sim: " << *err << "\n";
    return 2;
  }
  if (!(streams.pose_rate_hz >= 0.0 && streams.pose_rate_hz <= 10000.0)) {
    std::cerr << "loopd-sim: --pose-rate must be in [0, 10000] Hz\n";
    return 2;
  }

  loopd::Stopwatch total;
  const loopd::Drive drive = loopd::make_drive(cfg);
  if (!drive.error.empty()) {
    std::cerr << "loopd-sim: " << drive.error << "\n";
    return 2;
  }
  loopd::LogWriter writer;
  std::string error;
  if (!writer.open(out, &error)) {
    std::cerr << "loopd-sim: cannot open " << out << ": " << error << "\n";
    return loopd::tools::kExitUsage;
  }
  RunFigures run;
  run.threads = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const bool ok = write_drive(drive, streams, &writer, quiet, &run);
  writer.close();
  if (!ok) {
    std::cerr << "loopd-sim: write to " << out << " failed\n";
    return 1;
  }
  if (!movers_out.empty() && !(std::ofstream(movers_out) << loopd::movers_json(loopd::changing_movers(drive)) << "\n")) {
    std::cerr << "loopd-sim: cannot write " << movers_out << "\n";
    return 1;
  }
  run.seconds = total.ms() / 1000.0;
  print_summary(drive, out, json, run);
  return 0;
}
