#pragma once
/// @file loopd's HTTP endpoints (--http): the live page and its WebSocket feed (docs/web.md), /metrics (Prometheus text)
/// and /healthz, from the newest status_t the node made, the watchdog's verdict and the ViewFeed the engine's results go
/// into. The HTTP threads read only these: never the engine, the store or LCM.
#include <atomic>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include <loopd/status_t.hpp>

#include "loopd/runtime/node_config.hpp"
#include "loopd/web/http_server.hpp"
#include "loopd/web/view_clients.hpp"
#include "loopd/web/view_feed.hpp"

namespace loopd {

/// @brief The Prometheus text of a status: every status_t counter and gauge under a documented name (docs/metrics.md).
std::string metrics_of(const status_t& status, bool alive);

/// @brief The snapshot the endpoints answer from, and the live page's feed and clients.
class StatusEndpoints {
 public:
  explicit StatusEndpoints(const NodeConfig& node);
  /// @brief The newest status (called where status_t is published); also the page's health panel.
  void update(const status_t& status);
  /// @brief What the page shows: the engine's results go in through a ViewSink.
  ViewFeed& feed() { return feed_; }
  /// @brief Whether every pipeline stage makes progress (PipelineWatchdog::poll).
  void set_alive(bool alive) { alive_.store(alive); }
  /// @brief /metrics (503 until a first status), /healthz (200 "ok", 503 "stalled") and the page's files.
  std::map<std::string, HttpHandler> routes();
  /// @brief The page's WebSocket clients (/ws).
  ViewClients& clients() { return clients_; }
  const ViewClients& clients() const { return clients_; }
  const NodeConfig& node() const { return node_; }

 private:
  const NodeConfig& node_;
  ViewFeed feed_;
  ViewClients clients_{feed_, node_.http_view};
  std::mutex mutex_;
  std::optional<status_t> latest_;
  std::atomic<bool> alive_{true};
};

/// @brief Starts the server of `endpoints` for --http `listen` into `*server` and logs the page's URL ("" = none: true,
/// no server). False, with the reason logged, when it cannot listen: loopd then stops (exit 2). `*server` must go
/// before `endpoints` (its callbacks reach the page's clients).
bool serve_status(const std::string& listen, StatusEndpoints& endpoints, std::unique_ptr<HttpServer>* server);
/// @brief At the end of a run with --http: the pages served, dropped and the bytes sent to them (one line, info level).
void log_page_stats(const StatusEndpoints& endpoints, double seconds);

}  // namespace loopd
