#include "loopd/runtime/node_runtime.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "loopd/runtime/log_level.hpp"

namespace loopd {
namespace {

/// Fault injection for the crash test only: LOOPD_FAULT_CORRECTION_DELAY_MS (0 when unset).
int fault_correction_delay_ms() {
  const char* v = std::getenv("LOOPD_FAULT_CORRECTION_DELAY_MS");
  return v ? std::max(0, std::atoi(v)) : 0;
}

/// The map's first session, created on a new map (later sessions are written with their first keyframe, MapWriter).
bool ensure_session(MapStore& store, SessionId first_session, const std::string& sensor, const std::string& source) {
  const StoreResult<std::vector<SessionRecord>> sessions = store.sessions();
  StoreStatus status = sessions.status;
  if (status.ok() && sessions.value.empty()) {
    SessionRecord s;
    s.id = first_session;
    s.sensor = sensor;
    s.source = source;
    status = store.put_session(s);
  }
  if (!status.ok()) std::cerr << "loopd: cannot use the map: " << status.message << std::endl;
  return status.ok();
}

void log_resume(const MapStore& store, const ResumeSummary& r) {
  if (!log_enabled(LogLevel::kInfo)) return;
  std::fprintf(stderr, "loopd: map %s: %lld keyframes, %lld decisions, correction revision %lld restored in %.2f s", store.uri().c_str(),
               static_cast<long long>(r.keyframes), static_cast<long long>(r.decisions), static_cast<long long>(r.revision), r.seconds);
  if (r.dropped_undecided > 0)
    std::fprintf(stderr, "; %lld keyframe(s) cut off by the stop are processed again", static_cast<long long>(r.dropped_undecided));
  const std::size_t cut_off_corrections = r.corrections.size() - (r.ledger_corrected ? 1 : 0);
  if (cut_off_corrections > 0) std::fprintf(stderr, "; %zu correction(s) cut off by the stop made again", cut_off_corrections);
  if (r.keyframes_retired > 0) std::fprintf(stderr, "; %lld of the keyframes retired (poses only)", static_cast<long long>(r.keyframes_retired));
  if (r.loops_revoked > 0) std::fprintf(stderr, "; %lld loop(s) revoked by the loop ledger", static_cast<long long>(r.loops_revoked));
  if (r.ledger_corrected) std::fprintf(stderr, "; the ledger changed since the stored correction: the graph was solved again without them");
  if (!r.cut_off.empty())
    std::fprintf(stderr, "; their %zu decision(s) keep their event ids and are not published again when decided the same", r.cut_off.size());
  std::fprintf(stderr, "\n");
}

}  // namespace

NodeRuntime::~NodeRuntime() = default;

bool NodeRuntime::open_map() {
  if (node_.map.uri.empty()) return true;
  MapStoreConfig map = node_.map;
  map.read_only = map.read_only || node_.localize;  // localize: the map is never changed
  OpenedMapStore opened = open_map_store(map);
  if (!opened.status.ok()) {
    std::cerr << "loopd: cannot use the map: " << opened.status.message << std::endl;
    return false;
  }
  store_ = std::move(opened.store);
  const StoreResult<MapStats> stats = store_->stats();
  holds_keyframes_ = stats.ok() && stats.value.keyframes > 0;
  if (node_.localize && !holds_keyframes_) {
    std::cerr << "loopd: --localize: map " << store_->uri() << " holds no keyframes to localize in" << std::endl;
    return false;
  }
  return true;
}

bool NodeRuntime::start(const EngineConfig& config, EngineSink& output, const std::string& origin, bool skip_stored_keyframes) {
  EngineSink* first = &output;
  if (store_ && !node_.localize) {
    // The writer commits each record before passing it on; the republish filter keeps a resumed run from publishing
    // a decision twice; in a fleet the joint correction is published, not the detector's.
    if (node_.fleet.vehicle >= 0) fleet_output_ = std::make_unique<LocalCorrectionFilter>(output);
    republish_ = std::make_unique<RepublishFilter>(fleet_output_ ? static_cast<EngineSink&>(*fleet_output_) : output);
    writer_ = std::make_unique<MapWriter>(*store_, *republish_, node_.log_every_n, fault_correction_delay_ms());
    writer_->set_session_origin(config.detector.sensor, origin);
    writer_->set_max_buffered_keyframes(node_.max_buffered_keyframes);
    writer_->set_retry_period(node_.map_retry_period);
    first = writer_.get();
  }
  if (const auto stall = FaultStallSink::from_environment()) {
    std::fprintf(stderr, "loopd: TEST-ONLY fault armed: the sequential stage stalls %d ms at keyframe %lld\n", stall->second,
                 static_cast<long long>(stall->first));
    stall_ = std::make_unique<FaultStallSink>(*first, stall->first, stall->second);
    first = stall_.get();
  }
  engine_ = std::make_unique<LoopdEngine>(config, first);
  if (store_) {
    // The engine reads keyframes' prepared scans back from the map (bounded cache) and stores map clouds there. To
    // localize, the run's own keyframes live in the cache only (nothing is written), and no map cloud is made.
    if (node_.map_cache_mb > 0.0) engine_->keep_features_in_store(*store_, static_cast<std::size_t>(node_.map_cache_mb * 1048576.0));
    if (!node_.localize) engine_->make_map_clouds();
  }
  return resume(config, origin, skip_stored_keyframes) && join_fleet(config, output);
}

bool NodeRuntime::resume(const EngineConfig& config, const std::string& origin, bool skip_stored_keyframes) {
  if (!store_) return true;
  if (!node_.localize && !ensure_session(*store_, config.sessions.first_session, config.detector.sensor, origin)) return false;
  const ResumeSummary r = engine_->resume(*store_, skip_stored_keyframes, node_.localize);
  if (!r.ok) {
    std::cerr << "loopd: " << r.error << std::endl;
    return false;
  }
  if (republish_) republish_->expect(r.cut_off_published);
  log_resume(*store_, r);
  if (node_.localize && log_enabled(LogLevel::kInfo))
    std::fprintf(stderr, "loopd: localizing in %s (read-only): this run's keyframes are a new session, in memory only\n", store_->uri().c_str());
  // Revocations entered while loopd runs reach the detector within map.ledger_poll (read on the sequential stage,
  // which owns the store).
  ledger_ = std::make_unique<LedgerWatch>(*store_, r.ledger, node_.ledger_poll);
  LedgerWatch* ledger = ledger_.get();
  engine_->set_ledger_feed([ledger] { return ledger->poll(); });
  return true;
}

bool NodeRuntime::join_fleet(const EngineConfig& config, EngineSink& output) {
  // Localizing in a shared map reads one vehicle's sessions (fleet.vehicle, 0 by default) as that vehicle left them and
  // writes nothing: it is not one of the fleet.
  if (node_.fleet.vehicle < 0 || !store_ || node_.localize) return true;
  // The fleet thread on its own connection feeds the engine the other vehicles' keyframes and publishes the joint
  // correction through `output`.
  const KeyframeLoad remote_load = node_.map_cache_mb > 0.0 ? KeyframeLoad::kDescriptor : KeyframeLoad::kFull;
  fleet_ = std::make_unique<FleetSync>(node_.fleet, node_.map, config.detector.correction, remote_load,
                                       [&output](const CorrectionOutput& c) { output.on_correction(c); });
  if (auto e = fleet_->start()) {
    std::cerr << "loopd: cannot join the fleet: " << *e << std::endl;
    fleet_.reset();
    return false;
  }
  FleetSync* feed = fleet_.get();
  engine_->set_remote_feed([feed] { return feed->take_remote(); });
  if (log_enabled(LogLevel::kInfo))
    std::fprintf(stderr, "loopd: fleet vehicle %d on %s: sessions from %d, the others' keyframes read every %.1f s\n", node_.fleet.vehicle,
                 store_->uri().c_str(), config.sessions.first_session, node_.fleet.poll_interval);
  return true;
}

MapStatus NodeRuntime::map_status(const EngineStats& s) const {
  MapStatus m;
  m.cached_bytes = s.bytes_per_keyframe * s.keyframes;
  if (!store_) return m;
  if (node_.map_cache_mb > 0.0) m.cached_bytes = s.cached_feature_bytes;
  m.path = store_->uri();
  m.bytes = store_->size_bytes();  // never waits for the store, which belongs to the writer's thread
  if (republish_) m.events_not_republished = republish_->not_republished();
  if (writer_) {
    const MapWriterStats w = writer_->stats();
    m.write_failures = w.failures;
    m.write_retries = w.busy_retries + w.retries;
    m.writes_buffered = w.buffered;
    m.last_error = w.last_error;
  }
  return m;
}

void NodeRuntime::finish() {
  if (engine_) engine_->finish();
  if (writer_ && !writer_->flush(node_.fleet.flush_timeout)) {
    const MapWriterStats w = writer_->stats();
    std::fprintf(stderr, "loopd: MAP WRITES LOST: %lld write(s) still waited for the map server after %.0f s: %s\n",
                 static_cast<long long>(w.buffered), node_.fleet.flush_timeout, w.last_error.c_str());
  }
  if (fleet_) fleet_->stop();
}

}  // namespace loopd
