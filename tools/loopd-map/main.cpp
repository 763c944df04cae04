// loopd-map: what a loopd map file holds (loopd --map FILE): info, trajectory, loops, check. Opens the map read-only,
// so it can run while loopd writes to it and never creates a file.
#include <CLI/CLI.hpp>
#include <iostream>
#include <unistd.h>

#include "map_commands.hpp"
#include "open_map.hpp"

using namespace loopd::tools;

int main(int argc, char** argv) {
  CLI::App app{"loopd-map: inspect a loopd map (loopd --map FILE), read-only"};
  std::string path;
  CommandOptions options;
  bool quiet = false;
  app.add_option("FILE", path, "the map file (FILE or sqlite://FILE)")->required();
  app.add_flag("--json", options.json, "print one JSON object as the last stdout line");
  app.add_flag("--quiet", quiet, "no progress bar");
  app.require_subcommand(1);
  CLI::App* info = app.add_subcommand("info", "sessions, keyframes, loops, correction revision, bytes on disk");
  CLI::App* trajectory = app.add_subcommand("trajectory", "one pose per keyframe: corrected (as loopd publishes them) or odometry");
  TrajectoryOptions traj;
  trajectory->add_option("--format", traj.format, "tum (stamps in seconds) or kitti")->check(CLI::IsMember({"tum", "kitti"}))->capture_default_str();
  trajectory->add_flag("--odometry", traj.odometry, "odometry poses (T_odom_sensor) instead of the corrected ones");
  trajectory->add_option("--out", traj.out, "file to write (default: stdout)");
  CLI::App* loops = app.add_subcommand("loops", "loop decisions: accepted ones, or every one with --all");
  bool all = false;
  loops->add_flag("--all", all, "rejected decisions too");
  CLI::App* check = app.add_subcommand("check", "SQLite integrity check and the map's invariants; exit 1 when either fails");
  for (CLI::App* sub : {info, trajectory, loops, check}) sub->fallthrough();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitBadInput;
  }
  options.progress = !quiet && ::isatty(STDERR_FILENO) == 1;

  ReadOnlyMap map = open_map_read_only(path);
  if (!map.store) {
    std::cerr << "loopd-map: " << map.error << "\n";
    return kExitBadInput;
  }
  if (info->parsed()) return run_info(*map.store, options);
  if (trajectory->parsed()) return run_trajectory(*map.store, traj, options);
  if (loops->parsed()) return run_loops(*map.store, all, options);
  return run_check(*map.store, options);
}
