#pragma once
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>

#include "loopd/runtime/node_config.hpp"

namespace loopd {

/// @brief Live: subscribes on the bus, the LCM thread only decodes and enqueues, an ingest thread feeds the
///        engine; runs until `stop` becomes true. Under systemd (NOTIFY_SOCKET) it notifies READY=1 once the map is open
///        and both channels are subscribed, STATUS= lines, WATCHDOG=1 while the pipeline makes progress, and STOPPING=1
///        at the stop. Returns 2 when the map cannot be used, 3 when LCM cannot be initialised or fails while handling.
int run_live(const NodeConfig& node, const EngineConfig& engine, const std::atomic<bool>& stop, RunSummary* summary);

/// @brief Replay: reads an lcm-logger file through LCM's file provider as fast as possible, waits for the workers
///        instead of dropping, and writes every published message to `output_log` (and to `publish_url` when set).
int run_replay(const NodeConfig& node, const EngineConfig& engine, const std::string& input_log, const std::string& output_log,
               const std::string& publish_url, const std::atomic<bool>& stop, RunSummary* summary);

/// @brief Warns (one line on stderr) when the UDP receive buffer cannot hold a scan of `points` points.
///        Returns true when a warning was printed.
bool check_receive_buffer(const std::string& lcm_url, std::int64_t points);

}  // namespace loopd
