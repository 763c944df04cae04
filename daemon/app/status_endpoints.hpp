#pragma once
/// @file loopd's HTTP endpoints (--http): /metrics (Prometheus text) and /healthz, from the newest status_t the node
/// made and the watchdog's verdict. The HTTP threads read only this snapshot: never the engine, the store or LCM.
#include <atomic>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include <loopd/status_t.hpp>

#include "loopd/web/http_server.hpp"

namespace loopd {

/// @brief The Prometheus text of a status: every status_t counter and gauge under a documented name (docs/metrics.md).
std::string metrics_of(const status_t& status, bool alive);

/// @brief The snapshot the endpoints answer from.
class StatusEndpoints {
 public:
  /// @brief The newest status (called where status_t is published).
  void update(const status_t& status);
  /// @brief Whether every pipeline stage makes progress (PipelineWatchdog::poll).
  void set_alive(bool alive) { alive_.store(alive); }
  /// @brief /metrics (503 until a first status) and /healthz (200 "ok", 503 "stalled").
  std::map<std::string, HttpHandler> routes();

 private:
  std::mutex mutex_;
  std::optional<status_t> latest_;
  std::atomic<bool> alive_{true};
};

/// @brief Starts the server of `endpoints` for --http `listen` into `*server` and logs its URL ("" = none: true, no
/// server). False, with the reason logged, when it cannot listen: loopd then stops (exit 2).
bool serve_status(const std::string& listen, StatusEndpoints& endpoints, std::unique_ptr<HttpServer>* server);

}  // namespace loopd
