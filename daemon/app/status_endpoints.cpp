#include "status_endpoints.hpp"

#include <cstdio>

#include "loopd/runtime/log_level.hpp"
#include "loopd/web/metrics_text.hpp"
#include "loopd/web/page_files.hpp"

namespace loopd {

std::string metrics_of(const status_t& s, bool alive) {
  MetricsText m;
  const auto per_channel = [&](const char* name, const char* help, std::int64_t channel_stats_t::*count) {
    std::vector<std::pair<std::string, double>> samples;
    for (const channel_stats_t& c : s.channels) samples.emplace_back(c.channel, static_cast<double>(c.*count));
    m.counter(name, help, "channel", samples);
  };
  struct Figure {
    bool counter;  ///< else a gauge
    const char* name;
    const char* help;
    double value;
  };
  const auto v = [](auto x) { return static_cast<double>(x); };
  const Figure before_channels[] = {
      {false, "loopd_up", "1 while the pipeline makes progress (as /healthz), 0 when a stage stalls.", alive ? 1.0 : 0.0},
      {false, "loopd_uptime_seconds", "Seconds since loopd started (data time in a replay).", s.uptime_s},
      {false, "loopd_status_timestamp_seconds", "Time of the status these figures come from [s since the epoch].", v(s.utime) * 1e-6},
  };
  const Figure after_channels[] = {
      {false, "loopd_pending_scans", "Scans waiting for a pose.", v(s.pending_scans)},
      {false, "loopd_queue_depth", "Keyframe jobs waiting for a worker.", v(s.queue_depth)},
      {true, "loopd_shed_total", "Keyframes shed (pose kept, no features) because the queue was full.", v(s.shed)},
      {true, "loopd_invalid_scans_total", "Scans discarded: NaN-only, empty, duplicate or out-of-order time.", v(s.invalid_scans)},
      {true, "loopd_scans_lost_estimate_total", "Scans that never arrived, estimated from gaps in the scan rate.", v(s.scans_lost_estimate)},
      {true, "loopd_clock_jumps_total", "Times the data clock jumped and loopd followed it.", v(s.clock_jumps)},
      {true, "loopd_odometry_resets_total", "Odometry resets (the trajectory continued from the last pose before).", v(s.odometry_resets)},
      {true, "loopd_sensor_changes_total", "Changes of the sensor layout beyond normal variation.", v(s.sensor_changes)},
      {false, "loopd_keyframes", "Keyframes held (restored from the map included).", v(s.keyframes)},
      {true, "loopd_keyframes_deskewed_total", "Keyframe scans motion-compensated from their point times.", v(s.keyframes_deskewed)},
      {true, "loopd_deskew_skipped_total", "Keyframe scans with point times left as they came.", v(s.deskew_skipped)},
      {true, "loopd_keyframes_skipped_total", "Scans recognised as keyframes the map already holds and skipped.", v(s.keyframes_skipped)},
      {false, "loopd_bytes_per_keyframe", "Bytes held per keyframe, averaged.", v(s.bytes_per_keyframe)},
      {true, "loopd_loops_accepted_total", "Loop candidates accepted (restored from the map included).", v(s.loops_accepted)},
      {true, "loopd_loops_rejected_total", "Loop candidates rejected (restored from the map included).", v(s.loops_rejected)},
      {true, "loopd_events_not_republished_total", "Loop events decided again the same after a restart and not published twice.",
       v(s.events_not_republished)},
      {false, "loopd_session", "The session this run's keyframes go to.", v(s.session)},
      {true, "loopd_sessions_opened_total", "Sessions this run opened (another drive, an odometry reset).", v(s.sessions_opened)},
      {false, "loopd_resident_memory_bytes", "Resident memory of the process [bytes].", v(s.memory_bytes)},
      {false, "loopd_map_bytes", "Bytes of the map on disk (0 in memory only).", v(s.map_bytes)},
      {false, "loopd_map_cached_feature_bytes", "Bytes of keyframe features held in memory.", v(s.map_cached_bytes)},
      {true, "loopd_map_write_failures_total", "Map writes given up (non-zero: the map is no longer complete).", v(s.map_write_failures)},
      {true, "loopd_map_write_retries_total", "Map writes tried again (map busy or its server away).", v(s.map_write_retries)},
      {false, "loopd_map_writes_buffered", "Map writes waiting in memory for the map.", v(s.map_writes_buffered)},
  };
  const auto add = [&m](const Figure& f) { f.counter ? m.counter(f.name, f.help, f.value) : m.gauge(f.name, f.help, f.value); };
  for (const Figure& f : before_channels) add(f);
  per_channel("loopd_channel_received_total", "Messages received per input channel.", &channel_stats_t::received);
  per_channel("loopd_channel_accepted_total", "Messages accepted per input channel.", &channel_stats_t::accepted);
  per_channel("loopd_channel_malformed_total", "Messages that did not decode per input channel (counted, skipped).", &channel_stats_t::malformed);
  per_channel("loopd_channel_dropped_total", "Messages dropped per input channel (input queue full).", &channel_stats_t::dropped);
  for (const Figure& f : after_channels) add(f);
  m.gauge("loopd_descriptor_device_info", "The device computing descriptors (1 for the one in use).", 1, "device", s.device);
  return m.text();
}

StatusEndpoints::StatusEndpoints(const NodeConfig& node) : node_(node) {}

void StatusEndpoints::update(const status_t& s) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = s;
  }
  if (node_.http_listen.empty()) return;
  const auto v = [](auto x) { return static_cast<double>(x); };
  const double scans = s.channels.empty() ? 0.0 : v(s.channels[0].received);  // the scan channel comes first
  const std::string role = node_.localize             ? "localizing in the map (read-only)"
                           : node_.fleet.vehicle >= 0 ? "fleet vehicle " + std::to_string(node_.fleet.vehicle)
                                                      : "single vehicle";
  const ViewClients::Stats page = clients_.stats();
  feed_.set_health({{"scans_received", scans},
                    {"keyframes", v(s.keyframes)},
                    {"loops_accepted", v(s.loops_accepted)},
                    {"loops_rejected", v(s.loops_rejected)},
                    {"queue_depth", v(s.queue_depth)},
                    {"pending_scans", v(s.pending_scans)},
                    {"shed", v(s.shed)},
                    {"invalid_scans", v(s.invalid_scans)},
                    {"scans_lost_estimate", v(s.scans_lost_estimate)},
                    {"resident_memory_bytes", v(s.memory_bytes)},
                    {"map_bytes", v(s.map_bytes)},
                    {"map_writes_buffered", v(s.map_writes_buffered)},
                    {"map_write_retries", v(s.map_write_retries)},
                    {"map_write_failures", v(s.map_write_failures)},
                    {"session", v(s.session)},
                    {"uptime_s", s.uptime_s},
                    {"pages_connected", v(page.connected)}},
                   {{"watchdog", alive_.load() ? "ok" : "stalled"},
                    {"role", role},
                    {"map", s.map_path.empty() ? "in memory" : s.map_path},
                    {"map_error", s.map_error},
                    {"device", s.device}});
}

std::map<std::string, HttpHandler> StatusEndpoints::routes() {
  std::map<std::string, HttpHandler> routes = page_routes(find_page_dir());
  routes.merge(std::map<std::string, HttpHandler>{
      {"/metrics",
       [this] {
         std::optional<status_t> s;
         {
           std::lock_guard<std::mutex> lock(mutex_);
           s = latest_;
         }
         if (!s) return HttpResponse{503, "text/plain; charset=utf-8", "no status yet\n"};
         const ViewClients::Stats page = clients_.stats();
         MetricsText web;
         web.gauge("loopd_http_page_clients", "Live pages connected now (WebSocket).", static_cast<double>(page.connected));
         web.counter("loopd_http_page_clients_dropped_total", "Live pages dropped because they did not read.", static_cast<double>(page.dropped));
         web.counter("loopd_http_page_sent_bytes_total", "Bytes sent to live pages.", static_cast<double>(page.bytes_sent));
         return HttpResponse{200, MetricsText::content_type(), metrics_of(*s, alive_.load()) + web.text()};
       }},
      {"/healthz", [this] {
         return alive_.load() ? HttpResponse{200, "text/plain; charset=utf-8", "ok\n"}
                              : HttpResponse{503, "text/plain; charset=utf-8", "stalled: a pipeline stage makes no progress\n"};
       }}});
  return routes;
}

bool serve_status(const std::string& listen, StatusEndpoints& endpoints, std::unique_ptr<HttpServer>* server) {
  if (listen.empty()) return true;
  std::string error;
  const std::optional<HttpListen> where = parse_http_listen(listen, &error);
  if (where) {
    HttpServerConfig config;
    config.listen = *where;
    config.websocket_clients = endpoints.node().http_view.max_clients;
    config.threads = 2 + config.websocket_clients;  // each page holds a thread; two more for scrapes and files
    *server = HttpServer::start(config, endpoints.routes(), &error);
    if (*server) (*server)->add_websocket("/ws", endpoints.clients().service());
  }
  if (!*server) {
    std::fprintf(stderr, "loopd: --http %s: %s\n", listen.c_str(), error.c_str());
    return false;
  }
  if (log_enabled(LogLevel::kInfo))
    std::fprintf(stderr, "loopd: http: live page %s/ (metrics %s/metrics, health %s/healthz)\n", (*server)->url().c_str(), (*server)->url().c_str(),
                 (*server)->url().c_str());
  return true;
}

void log_page_stats(const StatusEndpoints& endpoints, double seconds) {
  if (endpoints.node().http_listen.empty() || !log_enabled(LogLevel::kInfo)) return;
  const ViewClients::Stats s = endpoints.clients().stats();
  std::fprintf(stderr, "loopd: http: %lld live pages served, %lld dropped, %lld bytes sent to them (%.0f bytes/s over %.1f s)\n",
               static_cast<long long>(s.served), static_cast<long long>(s.dropped), static_cast<long long>(s.bytes_sent),
               seconds > 0.0 ? static_cast<double>(s.bytes_sent) / seconds : 0.0, seconds);
}

}  // namespace loopd
