#include "status_endpoints.hpp"

#include <cstdio>

#include "loopd/runtime/log_level.hpp"
#include "loopd/web/metrics_text.hpp"

namespace loopd {

std::string metrics_of(const status_t& s, bool alive) {
  MetricsText m;
  m.gauge("loopd_up", "1 while the pipeline makes progress (as /healthz), 0 when a stage stalls.", alive ? 1 : 0);
  m.gauge("loopd_uptime_seconds", "Seconds since loopd started (data time in a replay).", s.uptime_s);
  m.gauge("loopd_status_timestamp_seconds", "Time of the status these figures come from [s since the epoch].", static_cast<double>(s.utime) * 1e-6);
  std::vector<std::pair<std::string, double>> received, accepted, malformed, dropped;
  for (const channel_stats_t& c : s.channels) {
    received.emplace_back(c.channel, static_cast<double>(c.received));
    accepted.emplace_back(c.channel, static_cast<double>(c.accepted));
    malformed.emplace_back(c.channel, static_cast<double>(c.malformed));
    dropped.emplace_back(c.channel, static_cast<double>(c.dropped));
  }
  m.counter("loopd_channel_received_total", "Messages received per input channel.", "channel", received);
  m.counter("loopd_channel_accepted_total", "Messages accepted per input channel.", "channel", accepted);
  m.counter("loopd_channel_malformed_total", "Messages that did not decode per input channel (counted, skipped).", "channel", malformed);
  m.counter("loopd_channel_dropped_total", "Messages dropped per input channel (input queue full).", "channel", dropped);
  m.gauge("loopd_pending_scans", "Scans waiting for a pose.", s.pending_scans);
  m.gauge("loopd_queue_depth", "Keyframe jobs waiting for a worker.", s.queue_depth);
  m.counter("loopd_shed_total", "Keyframes shed (pose kept, no features) because the queue was full.", static_cast<double>(s.shed));
  m.counter("loopd_invalid_scans_total", "Scans discarded: NaN-only, empty, duplicate or out-of-order time.", static_cast<double>(s.invalid_scans));
  m.counter("loopd_scans_lost_estimate_total", "Scans that never arrived, estimated from gaps in the scan rate.",
            static_cast<double>(s.scans_lost_estimate));
  m.counter("loopd_clock_jumps_total", "Times the data clock jumped and loopd followed it.", static_cast<double>(s.clock_jumps));
  m.counter("loopd_odometry_resets_total", "Odometry resets (the trajectory continued from the last pose before).",
            static_cast<double>(s.odometry_resets));
  m.counter("loopd_sensor_changes_total", "Changes of the sensor layout beyond normal variation.", static_cast<double>(s.sensor_changes));
  m.gauge("loopd_keyframes", "Keyframes held (restored from the map included).", static_cast<double>(s.keyframes));
  m.counter("loopd_keyframes_deskewed_total", "Keyframe scans motion-compensated from their point times.", static_cast<double>(s.keyframes_deskewed));
  m.counter("loopd_deskew_skipped_total", "Keyframe scans with point times left as they came.", static_cast<double>(s.deskew_skipped));
  m.counter("loopd_keyframes_skipped_total", "Scans recognised as keyframes the map already holds and skipped.",
            static_cast<double>(s.keyframes_skipped));
  m.gauge("loopd_bytes_per_keyframe", "Bytes held per keyframe, averaged.", static_cast<double>(s.bytes_per_keyframe));
  m.counter("loopd_loops_accepted_total", "Loop candidates accepted (restored from the map included).", static_cast<double>(s.loops_accepted));
  m.counter("loopd_loops_rejected_total", "Loop candidates rejected (restored from the map included).", static_cast<double>(s.loops_rejected));
  m.counter("loopd_events_not_republished_total", "Loop events decided again the same after a restart and not published twice.",
            static_cast<double>(s.events_not_republished));
  m.gauge("loopd_session", "The session this run's keyframes go to.", static_cast<double>(s.session));
  m.counter("loopd_sessions_opened_total", "Sessions this run opened (another drive, an odometry reset).", static_cast<double>(s.sessions_opened));
  m.gauge("loopd_resident_memory_bytes", "Resident memory of the process [bytes].", static_cast<double>(s.memory_bytes));
  m.gauge("loopd_map_bytes", "Bytes of the map on disk (0 in memory only).", static_cast<double>(s.map_bytes));
  m.gauge("loopd_map_cached_feature_bytes", "Bytes of keyframe features held in memory.", static_cast<double>(s.map_cached_bytes));
  m.counter("loopd_map_write_failures_total", "Map writes given up (non-zero: the map is no longer complete).",
            static_cast<double>(s.map_write_failures));
  m.counter("loopd_map_write_retries_total", "Map writes tried again (map busy or its server away).", static_cast<double>(s.map_write_retries));
  m.gauge("loopd_map_writes_buffered", "Map writes waiting in memory for the map.", static_cast<double>(s.map_writes_buffered));
  m.gauge("loopd_descriptor_device_info", "The device computing descriptors (1 for the one in use).", 1, "device", s.device);
  return m.text();
}

void StatusEndpoints::update(const status_t& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_ = status;
}

std::map<std::string, HttpHandler> StatusEndpoints::routes() {
  return {{"/metrics",
           [this] {
             std::optional<status_t> s;
             {
               std::lock_guard<std::mutex> lock(mutex_);
               s = latest_;
             }
             if (!s) return HttpResponse{503, "text/plain; charset=utf-8", "no status yet\n"};
             return HttpResponse{200, MetricsText::content_type(), metrics_of(*s, alive_.load())};
           }},
          {"/healthz", [this] {
             return alive_.load() ? HttpResponse{200, "text/plain; charset=utf-8", "ok\n"}
                                  : HttpResponse{503, "text/plain; charset=utf-8", "stalled: a pipeline stage makes no progress\n"};
           }}};
}

bool serve_status(const std::string& listen, StatusEndpoints& endpoints, std::unique_ptr<HttpServer>* server) {
  if (listen.empty()) return true;
  std::string error;
  const std::optional<HttpListen> where = parse_http_listen(listen, &error);
  if (where) {
    HttpServerConfig config;
    config.listen = *where;
    *server = HttpServer::start(config, endpoints.routes(), &error);
  }
  if (!*server) {
    std::fprintf(stderr, "loopd: --http %s: %s\n", listen.c_str(), error.c_str());
    return false;
  }
  if (log_enabled(LogLevel::kInfo))
    std::fprintf(stderr, "loopd: http: %s/metrics and %s/healthz\n", (*server)->url().c_str(), (*server)->url().c_str());
  return true;
}

}  // namespace loopd
