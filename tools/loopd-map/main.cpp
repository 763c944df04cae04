// loopd-map: what a loopd map file holds (loopd --map FILE): info, trajectory, loops, check, the live page of it
// (serve), and the 3D map built from it (export-cloud, export-octomap, picture); and the loop ledger (loops --revoke /
// --restore, ledger, correct). Opens the map read-only, so it can run while loopd writes to it, except for the ledger's writes and correct; never
// creates a map.
#include <CLI/CLI.hpp>
#include <iostream>
#include <unistd.h>
#include <vector>

#ifdef LOOPD_WITH_OCTOMAP
#include "map_build_options.hpp"
#endif
#include "map_commands.hpp"
#include "open_map.hpp"

using namespace loopd::tools;

namespace {

/// The loop ledger's options and commands: loops --revoke / --restore [--reason] [--who], ledger, correct.
struct LedgerCli {
  LedgerEntryOptions entry;
  std::int64_t revoke_event = -1, restore_event = -1;
  CLI::Option *revoke = nullptr, *restore = nullptr, *reason = nullptr, *who = nullptr;
  CLI::App *ledger = nullptr, *correct = nullptr;
  CorrectOptions correct_options;
  bool entry_given() const { return revoke->count() > 0 || restore->count() > 0; }
};

void add_ledger_options(CLI::App& app, CLI::App& loops, LedgerCli& cli) {
  cli.revoke = loops.add_option("--revoke", cli.revoke_event, "revoke this accepted loop (event id): no later correction uses it")
                   ->check(CLI::NonNegativeNumber);
  cli.restore = loops.add_option("--restore", cli.restore_event, "restore this revoked loop (event id)")->check(CLI::NonNegativeNumber);
  cli.reason = loops.add_option("--reason", cli.entry.reason, "with --revoke / --restore: why (kept in the ledger)");
  cli.who = loops.add_option("--who", cli.entry.who, "with --revoke / --restore: who (default: the login name)");
  for (CLI::Option* o : {cli.revoke, cli.restore}) o->excludes(loops.get_option("--suspect"))->excludes(loops.get_option("--all"));
  cli.revoke->excludes(cli.restore);
  cli.ledger = app.add_subcommand("ledger", "the loop ledger: every revoke and restore, who, when, why; the loops revoked now");
  cli.correct = app.add_subcommand(
      "correct", "make the map's correction again with every accepted loop the ledger leaves (one pose-graph solve); loopd stopped");
  cli.correct->add_option("--config", cli.correct_options.config,
                          "loopd's YAML config the map was made with (correction.*); default: loopd's defaults");
}

int run_ledger_cli(loopd::MapStore& store, LedgerCli& cli, const CommandOptions& options) {
  if (!cli.entry_given()) {
    std::cerr << "loopd-map: --reason and --who go with --revoke or --restore\n";
    return kExitBadInput;
  }
  cli.entry.revoke = cli.revoke->count() > 0;
  cli.entry.event_id = cli.entry.revoke ? cli.revoke_event : cli.restore_event;
  return run_ledger_entry(store, cli.entry, options);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loopd-map: inspect a loopd map (loopd --map FILE), read-only; revoke or restore its loops and correct it again"};
  std::string path;
  CommandOptions options;
  bool quiet = false;
  app.add_option("FILE", path, "the map: FILE, sqlite://FILE, or postgresql://... (a fleet map: every vehicle)")->required();
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
  LoopsOptions loops_options;
  loops->add_flag("--all", loops_options.all, "rejected decisions too");
  CLI::Option* suspect = loops->add_flag("--suspect", loops_options.suspect,
                                         "the accepted loops that the stored correction fits worst (residual of T_match_query), largest first");
  loops->add_option("--limit", loops_options.limit, "with --suspect: how many")->check(CLI::PositiveNumber)->capture_default_str();
  suspect->excludes(loops->get_option("--all"));
  LedgerCli ledger_cli;
  add_ledger_options(app, *loops, ledger_cli);
  CLI::App* check = app.add_subcommand("check", "SQLite integrity check and the map's invariants; exit 1 when either fails");
  CLI::App* serve = app.add_subcommand("serve", "the live page of this map (its sessions and every stored decision) until Ctrl-C");
  ServeOptions serve_options;
  serve->add_option("--http", serve_options.listen, "PORT (loopback) or IPV4:PORT")->required();
  serve->add_option("--clients", serve_options.clients, "pages at once")->check(CLI::Range(1, 64))->capture_default_str();
  serve->add_option("--clouds", serve_options.clouds, "map clouds of the newest keyframes shown")->check(CLI::Range(0, 1000))->capture_default_str();
  std::vector<CLI::App*> subs{info, trajectory, loops, check, serve, ledger_cli.ledger, ledger_cli.correct};
#ifdef LOOPD_WITH_OCTOMAP
  MapBuildOptions build;
  CLI::App* export_cloud = app.add_subcommand("export-cloud", "the 3D map (corrected poses, moving objects and noise removed) as .pcd or .ply");
  CLI::App* export_octomap = app.add_subcommand("export-octomap", "the occupancy octree of the map as OctoMap's .bt (octovis opens it)");
  CLI::App* picture =
      app.add_subcommand("picture", "a top view of the 3D map coloured by height, with the trajectory and the accepted loops, as PNG");
  for (CLI::App* sub : {export_cloud, export_octomap, picture}) {
    sub->add_option("--out", build.out, "file to write (.pcd or .ply; .bt; .png)")->required();
    sub->add_option("--session", build.session, "only this session's keyframes");
    sub->add_flag("--odometry", build.odometry, "odometry poses (the uncorrected map, for comparison)");
    sub->add_option("--resolution", build.resolution, "[m] octree leaf")->capture_default_str();
    sub->add_option("--ray-range", build.ray_range, "[m] rays clear free space up to this range")->capture_default_str();
    sub->add_option("--prob-hit", build.prob_hit, "occupancy probability of a leaf a ray ends in (OctoMap's sensor model)")->capture_default_str();
    sub->add_option("--prob-miss", build.prob_miss, "occupancy probability of a leaf a ray crosses (closer to 0.5: slower to clear)")
        ->capture_default_str();
    subs.push_back(sub);
  }
  for (CLI::App* sub : {export_cloud, picture}) {
    sub->add_option("--voxel", build.voxel, "[m] voxel of the written map (centroids, mean intensity)")->capture_default_str();
    sub->add_flag("--keep-moving", build.keep_moving, "no free-space clearing (moving objects stay)");
    sub->add_flag("--keep-roadway-noise", build.keep_roadway_noise, "no roadway-section filter (Ren 2019 Sec. 3.5)");
    sub->add_flag("--keep-outliers", build.keep_outliers, "no statistical outlier filter");
  }
  picture->add_option("--pixel", build.picture_cell, "[m] pixel size (default: the map in about 1400 pixels)")->check(CLI::NonNegativeNumber);
  picture->add_option("--cloud", build.picture_cloud, "draw this exported map (.pcd or .ply, from export-cloud) instead of building it again");
#endif
  for (CLI::App* sub : subs) sub->fallthrough();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitBadInput;
  }
  options.progress = !quiet && ::isatty(STDERR_FILENO) == 1;

  const bool writes = ledger_cli.correct->parsed() || ledger_cli.entry_given();
  ReadOnlyMap map = open_map_read_only(path, writes);
  if (!map.store) {
    std::cerr << "loopd-map: " << map.error << "\n";
    return kExitBadInput;
  }
  if (info->parsed()) return run_info(*map.store, options);
  if (trajectory->parsed()) return run_trajectory(*map.store, traj, options);
  if (loops->parsed() && (ledger_cli.entry_given() || ledger_cli.reason->count() > 0 || ledger_cli.who->count() > 0))
    return run_ledger_cli(*map.store, ledger_cli, options);
  if (loops->parsed()) return run_loops(*map.store, loops_options, options);
  if (ledger_cli.ledger->parsed()) return run_ledger(*map.store, options);
  if (serve->parsed()) return run_serve(*map.store, serve_options, options);
  if (ledger_cli.correct->parsed()) return run_correct(*map.store, ledger_cli.correct_options, options);
#ifdef LOOPD_WITH_OCTOMAP
  if (export_cloud->parsed()) return run_export_cloud(*map.store, build, options);
  if (export_octomap->parsed()) return run_export_octomap(*map.store, build, options);
  if (picture->parsed()) return run_picture(*map.store, build, options);
#endif
  return run_check(*map.store, options);
}
