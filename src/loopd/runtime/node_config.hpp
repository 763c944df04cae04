#pragma once
/// @file The settings of a loopd node around the engine (bus, map, fleet, published trajectory) and what a run reports.
#include <cstdint>
#include <optional>
#include <string>

#include "loopd/web/view_clients.hpp"

#include "loopd/runtime/fleet_sync.hpp"
#include "loopd/runtime/log_level.hpp"
#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/store/map_store.hpp"

namespace loopd {

/// @brief How much of the corrected trajectory each revision publishes (config keys output.*).
struct TrajectoryPublisherConfig {
  double min_move = 0.01;         ///< [m] a keyframe is published again when its corrected position moved more than this
  double min_turn_deg = 0.1;      ///< [deg] ... or its corrected orientation turned more than this
  double snapshot_period = 10.0;  ///< [s] of publication time between full snapshots; 0 = every revision is full (as before)
  std::optional<std::string> validate() const;
};

/// @brief LCM-facing settings of the daemon.
struct NodeConfig {
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  std::string scan_channel = "LIDAR_SCAN";
  std::string pose_channel = "ODOMETRY_POSE";
  std::string imu_channel = "IMU";  ///< gyro samples (imu_t), read where imu.enabled
  std::string loop_event_channel = "LOOP_EVENT";
  std::string trajectory_channel = "CORRECTED_TRAJECTORY";
  std::string status_channel = "LOOPD_STATUS";
  std::string localization_channel = "LOOPD_LOCALIZATION";  ///< localization_t per keyframe (--localize only)
  int input_queue_capacity = 256;                           ///< decoded messages waiting for the ingest thread (live); beyond it they are dropped
  int log_every_n = 100;                                    ///< a repeated anomaly is logged on its 1st, (N+1)th, ... occurrence
  double status_period = 1.0;                               ///< [s] status_t period (and the systemd STATUS= line's)
  /// [s] under systemd (WATCHDOG_USEC): WATCHDOG=1 pings stop when a pipeline stage has had work waiting this long
  /// without progress; systemd then restarts loopd after WatchdogSec=. Longer than the longest legitimate step: a
  /// pose-graph solve took up to ~20 s on 20,000 keyframes of a lap visited 45 times (max_nodes 4000).
  double watchdog_stall = 120.0;
  bool quiet = false;                    ///< no per-loop log lines
  LogLevel log_level = LogLevel::kInfo;  ///< which stderr lines are written (log_level: error, warn, info)
  /// The map store (map.path / --map): empty uri = everything in memory, as before.
  MapStoreConfig map;
  /// [MB] with a map: keyframe features beyond this LRU cache live only in the map (read back for candidates);
  /// 0: every keyframe's features stay in memory.
  double map_cache_mb = 512.0;
  /// How much of the corrected trajectory each revision publishes (output.*).
  TrajectoryPublisherConfig trajectory_output;
  FleetConfig fleet;                           ///< a fleet on one shared (postgresql://) map (fleet.*)
  std::int64_t max_buffered_keyframes = 5000;  ///< map.max_buffered_keyframes: writes kept while the map server is away
  double map_retry_period = 2.0;               ///< map.retry_period [s]: the longest pause between tries of writes waiting for the map
  double ledger_poll = 1.0;  ///< map.ledger_poll [s]: how often a running loopd reads the map's loop ledger (loopd-map loops --revoke)
  /// map.localize (--localize): the map is opened read-only and never changed; this run's keyframes are placed in it
  /// by loops to its keyframes (found without a pose prior, then gated) and published as a new session, in memory only.
  /// On a shared postgresql:// map it reads one vehicle's sessions (fleet.vehicle, 0 by default) on a read-only
  /// connection (a role with SELECT rights only is enough) and does not join the fleet.
  bool localize = false;
  /// http.listen (--http): serve the live page, /metrics and /healthz on "PORT" (loopback) or "IPV4:PORT"; "" = off
  /// (docs/web.md, docs/metrics.md)
  std::string http_listen;
  ViewClientsConfig http_view;  ///< http.clients, http.client_bytes_per_s: the live page's clients and what each may take
  std::optional<std::string> validate() const;
};

/// @brief Result of a run, for the exit summary.
struct RunSummary {
  EngineStats engine;
  std::int64_t scans_received = 0, poses_received = 0, malformed = 0, dropped_input = 0;
  std::int64_t events_written = 0;
  std::int64_t log_corrupt_headers = 0;  ///< replay: damaged event headers skipped in the input log
  double seconds = 0.0;
  double data_seconds = 0.0;
};

}  // namespace loopd
