#pragma once
/// @file One loopd run, live or replay alike: the map store (opened, resumed, written through MapWriter), the engine,
/// and in a fleet the fleet thread, wired in front of the output the daemon hands it. No transport in here.
#include <memory>
#include <string>

#include "loopd/runtime/fault_stall_sink.hpp"
#include "loopd/runtime/fleet_sync.hpp"
#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "loopd/runtime/node_config.hpp"
#include "loopd/runtime/republish_filter.hpp"

namespace loopd {

/// @brief The map store's part of a node's status (status_t, the systemd STATUS= line).
struct MapStatus {
  std::string path;                  ///< "" without a map (a server's password masked)
  std::int64_t bytes = 0;            ///< where the map lives (MapStore::size_bytes)
  std::int64_t cached_bytes = 0;     ///< keyframe features in memory
  std::int64_t write_failures = 0;   ///< writes given up (MapWriterStats::failures)
  std::int64_t write_retries = 0;    ///< busy retries and tries again from the buffer
  std::int64_t writes_buffered = 0;  ///< writes waiting for the map now
  std::int64_t events_not_republished = 0;
  std::string last_error;
};

/// @brief The chain every run builds: engine -> [map writer -> republish filter] -> [fleet: local correction filter]
/// -> output. Two steps, because a replay must know whether the map already holds keyframes before it opens its
/// output log: open_map(), then start(). Errors are printed (loopd's stderr) and returned as false.
class NodeRuntime {
 public:
  explicit NodeRuntime(const NodeConfig& node) : node_(node) {}
  NodeRuntime(const NodeRuntime&) = delete;
  NodeRuntime& operator=(const NodeRuntime&) = delete;
  ~NodeRuntime();

  /// @brief Opens node.map (nothing when no map is configured).
  bool open_map();
  /// @brief The opened map (null without one); read it only before start() (the writer owns it after).
  MapStore* map_before_start() { return engine_ ? nullptr : store_.get(); }
  /// @brief The opened map held keyframes (a run resumed on it).
  bool map_holds_keyframes() const { return holds_keyframes_; }

  /// @brief Builds the engine with `config` in front of `output`, resumes it from the map (`origin` names the source
  /// in the map's session record: "live URL", "replay FILE"; a replay skips the scans of stored keyframes) and, in a
  /// fleet, joins it.
  bool start(const EngineConfig& config, EngineSink& output, const std::string& origin, bool skip_stored_keyframes);

  LoopdEngine& engine() { return *engine_; }
  const LoopdEngine& engine() const { return *engine_; }
  MapStatus map_status(const EngineStats& stats) const;
  /// @brief Drains the engine, gives buffered map writes up to fleet.flush_timeout, ends the fleet's last round.
  void finish();

 private:
  bool resume(const EngineConfig& config, const std::string& origin, bool skip_stored_keyframes);
  bool join_fleet(const EngineConfig& config, EngineSink& output);

  const NodeConfig& node_;
  std::unique_ptr<MapStore> store_;
  bool holds_keyframes_ = false;
  std::unique_ptr<LocalCorrectionFilter> fleet_output_;  ///< in a fleet the joint correction is published, not the detector's
  std::unique_ptr<RepublishFilter> republish_;           ///< between the writer and the output
  std::unique_ptr<MapWriter> writer_;
  std::unique_ptr<FaultStallSink> stall_;  ///< TEST-ONLY (FaultStallSink::from_environment)
  std::unique_ptr<LedgerWatch> ledger_;    ///< the map's loop ledger, read by the engine's sequential stage
  std::unique_ptr<LoopdEngine> engine_;
  std::unique_ptr<FleetSync> fleet_;
};

}  // namespace loopd
