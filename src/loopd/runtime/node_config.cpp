#include "loopd/runtime/node_config.hpp"

#include "loopd/runtime/config_binder.hpp"
#include "loopd/store/store_uri.hpp"
#include "loopd/web/http_server.hpp"

#include <cmath>

namespace loopd {

std::optional<std::string> TrajectoryPublisherConfig::validate() const {
  if (!(min_move >= 0.0 && std::isfinite(min_move))) return "output.trajectory_min_move must be a finite number >= 0 [m]";
  if (!(min_turn_deg >= 0.0 && min_turn_deg <= 180.0)) return "output.trajectory_min_turn_deg must be in [0, 180] [deg]";
  if (!(snapshot_period >= 0.0 && snapshot_period <= 1e6)) return "output.trajectory_snapshot_period must be in [0, 1e6] [s]";
  return std::nullopt;
}

std::optional<std::string> NodeConfig::validate() const {
  if (lcm_url.empty()) return "lcm_url must not be empty";
  for (const auto* c : {&scan_channel, &pose_channel, &imu_channel, &loop_event_channel, &trajectory_channel, &status_channel, &localization_channel})
    if (c->empty()) return "channels: channel names must not be empty";
  if (input_queue_capacity < 1) return "input_queue_capacity must be >= 1";
  if (log_every_n < 1) return "log_every_n must be >= 1";
  if (!(status_period > 0.0 && status_period <= 1e6)) return "status_period must be in (0, 1e6] [s]";
  if (!(watchdog_stall > 0.0 && watchdog_stall <= 1e6)) return "watchdog_stall must be in (0, 1e6] [s]";
  if (!map.uri.empty())
    if (auto e = map.validate()) return "map: " + *e;
  if (!(map_cache_mb >= 0.0 && map_cache_mb <= 1e7)) return "map.cache_mb must be in [0, 1e7] [MB]";
  if (auto e = trajectory_output.validate()) return *e;
  if (auto e = fleet.validate()) return *e;
  if (fleet.vehicle >= 0 && !names_shared_map(map.uri)) return "fleet.vehicle needs a shared map (map.path postgresql://...)";
  if (max_buffered_keyframes < 1) return "map.max_buffered_keyframes must be >= 1";
  if (!(map_retry_period >= 0.1 && map_retry_period <= 600.0)) return "map.retry_period must be in [0.1, 600] s";
  if (!(ledger_poll >= 0.1 && ledger_poll <= 600.0)) return "map.ledger_poll must be in [0.1, 600] s";
  if (localize && map.uri.empty()) return "map.localize (--localize) needs a map (map.path / --map)";
  if (std::string e; !http_listen.empty() && !parse_http_listen(http_listen, &e)) return "http.listen (--http): " + e;
  if (http_view.max_clients < 0 || http_view.max_clients > 64) return "http.clients must be in [0, 64]";
  if (http_view.bytes_per_s < 4096 || http_view.bytes_per_s > (std::int64_t{1} << 30)) return "http.client_bytes_per_s must be in [4096, 2^30]";
  return std::nullopt;
}

void bind(Binder& b, NodeConfig& n) {
  b.field("lcm_url", n.lcm_url);
  b.field("channels.scan", n.scan_channel);
  b.field("channels.pose", n.pose_channel);
  b.field("channels.imu", n.imu_channel);
  b.field("channels.loop_event", n.loop_event_channel);
  b.field("channels.trajectory", n.trajectory_channel);
  b.field("channels.status", n.status_channel);
  b.field("channels.localization", n.localization_channel);
  b.field("input_queue_capacity", n.input_queue_capacity);
  b.field("log_every_n", n.log_every_n);
  b.field("status_period", n.status_period);
  b.field("watchdog_stall", n.watchdog_stall);
  b.choice("log_level", n.log_level, {{"error", LogLevel::kError}, {"warn", LogLevel::kWarn}, {"info", LogLevel::kInfo}});
  b.field("map.path", n.map.uri);
  b.field("map.synchronous", n.map.synchronous);
  b.field("map.cache_mb", n.map_cache_mb);
  b.field("map.max_buffered_keyframes", n.max_buffered_keyframes);
  b.field("map.retry_period", n.map_retry_period);
  b.field("map.ledger_poll", n.ledger_poll);
  b.field("map.localize", n.localize);
  b.field("http.listen", n.http_listen);
  b.field("http.clients", n.http_view.max_clients);
  b.field("http.client_bytes_per_s", n.http_view.bytes_per_s);
  b.field("fleet.vehicle", n.fleet.vehicle);
  b.field("fleet.poll_interval", n.fleet.poll_interval);
  b.field("fleet.solve_every_keyframes", n.fleet.solve_every_keyframes);
  b.field("fleet.flush_timeout", n.fleet.flush_timeout);
  b.field("output.trajectory_min_move", n.trajectory_output.min_move);
  b.field("output.trajectory_min_turn_deg", n.trajectory_output.min_turn_deg);
  b.field("output.trajectory_snapshot_period", n.trajectory_output.snapshot_period);
}

}  // namespace loopd
