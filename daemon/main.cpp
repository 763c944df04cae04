// loopd: the lidar loop-closure daemon. Thin glue: options -> config -> run_live / run_replay.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <unistd.h>

#include "loopd/runtime/daemon_config.hpp"
#include "loopd/base/sensor_estimate.hpp"
#include "loopd/runtime/heap_release.hpp"
#include "lcm_node.hpp"
#include "loopd/runtime/log_level.hpp"

namespace {
std::atomic<bool> g_stop{false};  // set only by the signal handler
extern "C" void on_signal(int) { g_stop.store(true); }

/// SIGHUP (what `systemctl reload` or a closed terminal sends) changes nothing: logs go to stderr, which loopd does not
/// open, and the config is read once at start. Said once on stderr (write(2): async-signal-safe), never fatal.
std::atomic<bool> g_hup_seen{false};
extern "C" void on_hangup(int) {
  if (g_hup_seen.exchange(true)) return;
  static const char kMessage[] = "loopd: SIGHUP ignored: nothing to reopen (logs go to stderr); restart loopd to apply a changed config\n";
  const ssize_t ignored = write(STDERR_FILENO, kMessage, sizeof(kMessage) - 1);
  (void)ignored;
}

/// SIGINT and SIGTERM stop loopd cleanly (the map is closed); SIGHUP is ignored with one log line.
void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  struct sigaction hup {};
  hup.sa_handler = on_hangup;
  sigemptyset(&hup.sa_mask);
  hup.sa_flags = SA_RESTART;
  sigaction(SIGHUP, &hup, nullptr);
}

void print_summary(const loopd::RunSummary& s, bool replay) {
  if (!loopd::log_enabled(loopd::LogLevel::kInfo)) return;
  const auto& e = s.engine;
  std::fprintf(stderr,
               "loopd: %s finished in %.1f s%s: scans %lld, poses %lld, keyframes %lld, loops accepted %lld, rejected %lld; "
               "malformed %lld, invalid scans %lld, scans without pose %lld, shed %lld, dropped %lld; scans lost (estimated) %lld, "
               "clock jumps %lld, odometry resets %lld, sensor changes %lld\n",
               replay ? "replay" : "live run", s.seconds,
               replay && s.seconds > 0 ? (" (" + std::to_string(s.data_seconds / s.seconds).substr(0, 5) + "x real time)").c_str() : "",
               static_cast<long long>(s.scans_received), static_cast<long long>(s.poses_received), static_cast<long long>(e.keyframes),
               static_cast<long long>(e.loops_accepted), static_cast<long long>(e.loops_rejected), static_cast<long long>(s.malformed),
               static_cast<long long>(e.invalid_scans), static_cast<long long>(e.dropped_no_pose), static_cast<long long>(e.shed),
               static_cast<long long>(s.dropped_input), static_cast<long long>(e.scans_lost_estimate), static_cast<long long>(e.clock_jumps),
               static_cast<long long>(e.odometry_resets), static_cast<long long>(e.sensor_changes));
  if (e.keyframes_deskewed + e.deskew_skipped > 0)
    std::fprintf(stderr,
                 "loopd: deskew: %lld keyframes deskewed (largest correction %.3f m), %lld with times not deskewed (poses not covering the sweep, or "
                 "a sweep too long)\n",
                 static_cast<long long>(e.keyframes_deskewed), e.deskew_max_correction, static_cast<long long>(e.deskew_skipped));
  if (e.sweeps_from_scans + e.sweeps_from_odometry > 0)
    std::fprintf(stderr,
                 "loopd: deskew: %lld sweeps with the motion their scans measured (%lld where the motion changed between two sweeps, %lld "
                 "with more than one turn rate, %lld bent as the gyro turned, %lld whose gyro disagreed), %lld with the odometry's (the scans "
                 "disagreed or did not register)\n",
                 static_cast<long long>(e.sweeps_from_scans), static_cast<long long>(e.sweeps_velocity_changed),
                 static_cast<long long>(e.sweeps_shape_refined), static_cast<long long>(e.sweeps_gyro), static_cast<long long>(e.sweeps_gyro_refused),
                 static_cast<long long>(e.sweeps_from_odometry));
  if (e.steps_measured + e.steps_refused + e.steps_skewed > 0)
    std::fprintf(stderr,
                 "loopd: steps: %lld keyframe steps measured by the scans, %lld left to the odometry (the registration was not believed), %lld "
                 "(scans that may be skewed: no per-point times, moving)\n",
                 static_cast<long long>(e.steps_measured), static_cast<long long>(e.steps_refused), static_cast<long long>(e.steps_skewed));
  if (e.keyframes_retired > 0)
    std::fprintf(stderr, "loopd: retirement: %lld keyframes retired where their place holds newer and better-connected ones (retirement.*)\n",
                 static_cast<long long>(e.keyframes_retired));
  if (e.keyframes_submapped > 0)
    std::fprintf(stderr, "loopd: submaps: %lld keyframes of a narrow or sparse sensor built from %.1f scans each on average (submap.*)\n",
                 static_cast<long long>(e.keyframes_submapped), static_cast<double>(e.submap_scans) / static_cast<double>(e.keyframes_submapped));
}
}  // namespace

int main(int argc, char** argv) {
  loopd::keep_large_allocations_in_heap();
  CLI::App app{
      "loopd: lidar loop-closure daemon. Listens for scans and odometry poses on LCM, detects and verifies loops\n"
      "(M2DP + plane-based 4PCS + GICP + Hungarian check), publishes loop events and corrected trajectories."};
  std::string lcm_url, config_path, replay_log, output_log, sensor, map_path, http_listen;
  int threads = -1, vehicle = -2;
  bool print_config = false, quiet = false, localize = false;
  app.set_version_flag("--version", std::string("loopd ") + LOOPD_VERSION);
  app.add_option("--lcm-url", lcm_url, "LCM URL to listen and publish on (default from config: udpm://239.255.76.67:7667?ttl=0)");
  app.add_option("--config", config_path, "YAML config file (see loopd.example.yaml); unknown or wrong fields are refused")->check(CLI::ExistingFile);
  app.add_option("--sensor", sensor,
                 "lidar model: auto (default: rings read from the scans) or a preset: " + loopd::sensor_choices() + " (overrides the config)");
  app.add_option("--threads", threads, "worker threads (0 = hardware threads; overrides the config)");
  app.add_option("--replay", replay_log, "process an lcm-logger file as fast as possible instead of listening live");
  app.add_option("--output", output_log, "with --replay: write every published message to this lcm-logger file");
  app.add_option("--map", map_path,
                 "map store: an SQLite file (created when missing) or a postgresql:// URI (a map shared by a fleet): "
                 "keyframes, loops and corrections outlive the process and a restart resumes (overrides map.path)");
  app.add_option("--vehicle", vehicle,
                 "fleet vehicle number (0-2146) on a shared postgresql:// map: its sessions, the others' keyframes as loop "
                 "candidates, one joint correction (overrides fleet.vehicle)");
  app.add_option("--http", http_listen,
                 "serve the live page (map, trajectory, loops, health), /metrics (Prometheus) and /healthz on PORT (loopback) or "
                 "IPV4:PORT (overrides http.listen; docs/web.md)");
  app.add_flag("--localize", localize,
               "with --map: localize in the map without changing it (opened read-only; this run's keyframes stay in memory; "
               "overrides map.localize)");
  app.add_flag("--print-config", print_config, "print the effective configuration as YAML and exit");
  app.add_flag("--quiet", quiet, "no log line per accepted loop");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // the exit status table (docs/tools.md): 2 = bad input or usage
  }

  loopd::DaemonConfig config;
  std::string error;
  if (!config_path.empty() && !loopd::load_config(config_path, &config, &error)) {
    std::cerr << "loopd: bad config: " << error << std::endl;
    return 2;
  }
  if (!sensor.empty() && !loopd::apply_sensor_preset(sensor, &config, &error)) {
    std::cerr << "loopd: --sensor: " << error << std::endl;
    return 2;
  }
  if (!lcm_url.empty()) config.node.lcm_url = lcm_url;
  if (threads >= 0) config.engine.num_threads = threads;
  if (!map_path.empty()) config.node.map.uri = map_path;
  if (vehicle != -2) config.node.fleet.vehicle = vehicle;
  if (localize) config.node.localize = true;
  if (!http_listen.empty()) config.node.http_listen = http_listen;
  config.node.quiet = quiet;
  loopd::apply_fleet(&config);
  if (auto e = config.node.validate()) {
    std::cerr << "loopd: bad config: " << *e << std::endl;
    return 2;
  }
  if (auto e = config.engine.validate()) {
    std::cerr << "loopd: bad config: " << *e << std::endl;
    return 2;
  }
  if (print_config) {
    std::cout << loopd::dump_config(config);
    return 0;
  }

  loopd::set_log_level(config.node.log_level);
  install_signal_handlers();
  loopd::RunSummary summary;
  int rc = 0;
  if (!replay_log.empty()) {
    rc = loopd::run_replay(config.node, config.engine, replay_log, output_log, lcm_url, g_stop, &summary);
  } else {
    if (!output_log.empty()) {
      std::cerr << "loopd: --output needs --replay (record a live run with lcm-logger)" << std::endl;
      return 2;
    }
    rc = loopd::run_live(config.node, config.engine, g_stop, &summary);
  }
  if (rc == 0) print_summary(summary, !replay_log.empty());
  return rc;
}
