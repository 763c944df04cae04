#pragma once
/// @file The loopd-map commands: each reads an opened map, prints a readable table and, with --json, one JSON object as
/// the last stdout line; each returns the tool's exit status.
#include <nlohmann/json.hpp>
#include <string>

#include "loopd/store/map_store.hpp"

namespace loopd::tools {

constexpr int kExitOk = 0, kExitCheckFailed = 1, kExitBadInput = 2;

/// @brief What every command is told besides the map.
struct CommandOptions {
  bool json = false;      ///< one JSON object as the last stdout line
  bool progress = false;  ///< progress bar on stderr while reading keyframes
};

/// @brief `info`: sessions, keyframe and loop counts, correction revision, bytes on disk.
int run_info(MapStore& store, const CommandOptions& options);

/// @brief What `trajectory` writes.
struct TrajectoryOptions {
  std::string format = "tum";  ///< "tum" or "kitti"
  bool odometry = false;       ///< T_odom_sensor instead of the corrected poses
  std::string out;             ///< file to write; empty: stdout
};
/// @brief `trajectory`: one pose per keyframe, corrected (as loopd publishes them) or odometry.
int run_trajectory(MapStore& store, const TrajectoryOptions& trajectory, const CommandOptions& options);

/// @brief `loops`: the accepted loop decisions (every decision when `all`).
/// @brief What `loops` lists: every decision (all), the accepted ones, or the accepted ones by their residual after the
/// stored correction, largest first (suspect: the loops an operator should look at first; at most `limit`).
struct LoopsOptions {
  bool all = false;
  bool suspect = false;
  int limit = 10;
};
int run_loops(MapStore& store, const LoopsOptions& loops, const CommandOptions& options);
/// @brief A score column of a loop table: "-" when the stage did not compute it (stored as a negative value).
std::string score_cell(double v);
/// @brief One loop decision as `loops --json` lists it.
nlohmann::json loop_json(const LoopDecision& r);
/// @brief `loops --suspect` (map_suspect.cpp).
int run_suspect_loops(MapStore& store, int limit, const CommandOptions& options);

/// @brief `loops --revoke EVENT` / `--restore EVENT`: one loop ledger entry.
struct LedgerEntryOptions {
  std::int64_t event_id = 0;
  bool revoke = true;  ///< false: restore
  std::string who;     ///< empty: the login name
  std::string reason;
};
/// @brief Appends the entry (map_ledger.cpp); exit 2 when the store refuses it (no such accepted loop, no change).
int run_ledger_entry(MapStore& store, const LedgerEntryOptions& entry, const CommandOptions& options);
/// @brief `ledger`: every entry, the loops revoked now, and the entry the stored correction honours.
int run_ledger(MapStore& store, const CommandOptions& options);

/// @brief `correct`: the map's correction made again from its keyframes and every loop the ledger leaves (map_correct.cpp).
struct CorrectOptions {
  std::string config;  ///< loopd's YAML config the map was made with (the correction's settings); empty: defaults
};
int run_correct(MapStore& store, const CorrectOptions& correct, const CommandOptions& options);

struct MapBuildOptions;
/// @brief `export-cloud`: the 3D map as .pcd / .ply (map_build_options.hpp).
int run_export_cloud(MapStore& store, const MapBuildOptions& build, const CommandOptions& options);
/// @brief `export-octomap`: the occupancy octree as OctoMap's .bt.
int run_export_octomap(MapStore& store, const MapBuildOptions& build, const CommandOptions& options);
/// @brief `picture`: a top view of the map (height colours, trajectory, accepted loops) as PNG.
int run_picture(MapStore& store, const MapBuildOptions& build, const CommandOptions& options);

/// @brief `serve`: the live page of a stored map (map_serve.cpp).
struct ServeOptions {
  std::string listen;  ///< "PORT" (loopback) or "IPV4:PORT"
  int clients = 4;     ///< pages at once
  int clouds = 40;     ///< map clouds of the newest keyframes shown
};
int run_serve(MapStore& store, const ServeOptions& serve, const CommandOptions& options);

/// @brief `check`: the store's integrity check and map invariants; kExitCheckFailed when it fails.
int run_check(MapStore& store, const CommandOptions& options);

}  // namespace loopd::tools
