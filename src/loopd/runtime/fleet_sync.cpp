#include "loopd/runtime/fleet_sync.hpp"

#include <pthread.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "loopd/runtime/log_level.hpp"
#include "loopd/fleet/joint_correction.hpp"
#include "loopd/records/vehicle_sessions.hpp"

namespace loopd {
namespace {

std::int64_t wall_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// @brief The map's keyframes and accepted loops as the joint correction takes them.
StoreStatus read_graph(SharedMap& shared, std::vector<JointKeyframe>* keyframes, std::vector<JointLoop>* loops) {
  StoreStatus s = shared.for_each_fleet_keyframe([&](MapKeyframe&& k) {
    keyframes->push_back({k.record.key, k.record.utime, k.record.T_odom_sensor, k.record.residual});
  });
  if (!s.ok()) return s;
  return shared.for_each_fleet_loop([&](LoopDecision&& r) {
    if (r.accepted()) loops->push_back({r.query, r.match, r.T_match_query, r.information, !r.confirmed});
  });
}

FleetCorrectionRecord to_record(const JointCorrection& solved, int vehicle, std::int64_t loops) {
  FleetCorrectionRecord r;
  r.solver_vehicle = vehicle;
  r.loops = loops;
  r.solved_utime = wall_utime();
  r.keys = solved.keys;
  r.T_map_sensor = solved.T_map_sensor;
  r.utimes = solved.utimes;
  for (const SessionAlignment& a : solved.sessions) r.sessions.push_back({a.session, a.anchored, a.T_map_session, a.num_keyframes});
  return r;
}

}  // namespace

std::optional<std::string> FleetConfig::validate() const {
  if (vehicle < -1 || vehicle > kMaxVehicle) return "fleet.vehicle must be in [0, " + std::to_string(kMaxVehicle) + "]";
  if (!(poll_interval >= 0.05 && poll_interval <= 3600.0)) return "fleet.poll_interval must be in [0.05, 3600] [s]";
  if (solve_every_keyframes < 1) return "fleet.solve_every_keyframes must be >= 1";
  if (!(flush_timeout >= 0.0 && flush_timeout <= 86400.0)) return "fleet.flush_timeout must be in [0, 86400] [s]";
  return std::nullopt;
}

CorrectionOutput to_correction_output(const FleetCorrectionRecord& record, int vehicle) {
  CorrectionOutput c;
  c.revision = record.revision;
  c.method = "fleet joint graph (vehicle " + std::to_string(record.solver_vehicle) + ")";
  c.keys = record.keys;
  c.utimes = record.utimes;
  c.T_map_sensor = record.T_map_sensor;
  for (const FleetCorrectionRecord::Session& s : record.sessions) {
    c.sessions.push_back({s.id, s.anchored, s.T_map_session, s.keyframes});
    if (vehicle_of(s.id) == vehicle && s.anchored) c.T_map_odom = s.T_map_session;  // sessions by id: the newest wins
  }
  return c;
}

FleetSync::FleetSync(const FleetConfig& config, MapStoreConfig map, LoopCorrectorConfig corrector, KeyframeLoad remote_load,
                     std::function<void(const CorrectionOutput&)> publish)
    : config_(config), map_config_(std::move(map)), corrector_(corrector), remote_load_(remote_load), publish_(std::move(publish)) {
  map_config_.vehicle = config.vehicle;
}

FleetSync::~FleetSync() { stop(); }

std::optional<std::string> FleetSync::start() {
  OpenedMapStore opened = open_map_store(map_config_);
  if (!opened.status.ok()) return opened.status.message;
  store_ = std::move(opened.store);
  shared_ = store_->shared();
  if (!shared_) return map_config_.uri + ": this map is not shared (a fleet needs a postgresql:// map)";
  thread_ = std::thread([this] { run(); });
  return std::nullopt;
}

void FleetSync::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void FleetSync::run() {
  pthread_setname_np(pthread_self(), "loopd-fleet");
  const auto period = std::chrono::milliseconds(static_cast<std::int64_t>(config_.poll_interval * 1000.0));
  for (bool last = false; !last;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, period, [this] { return stopping_; });
      last = stopping_;
    }
    round(last);
  }
  // The last round must reach the server (it may just be back: the store reconnects once a second).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<std::int64_t>(config_.flush_timeout * 1000.0));
  while (round_errors_ > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    round(true);
  }
}

void FleetSync::round(bool last) {
  round_errors_ = 0;
  read_remote();
  solve_if_due(last);
  publish_newest();
}

void FleetSync::read_remote() {
  std::vector<KeyframeRecord> fresh;
  const StoreStatus s = shared_->for_each_new_remote_keyframe(newest_seen_, remote_load_, [&](MapKeyframe&& k) {
    if (remote_load_ != KeyframeLoad::kFull && k.record.features) {  // the prepared scan stays in the store (read on demand)
      auto thin = std::make_shared<KeyframeFeatures>(*k.record.features);
      thin->prepared_in_store = true;
      k.record.features = std::move(thin);
    }
    fresh.push_back(std::move(k.record));
  });
  if (!s.ok()) error("reading the other vehicles' keyframes", s);
  if (fresh.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.remote_keyframes += static_cast<std::int64_t>(fresh.size());
  for (KeyframeRecord& k : fresh) inbox_.push_back(std::move(k));
}

void FleetSync::solve_if_due(bool last) {
  const StoreResult<bool> held = shared_->hold_solver_lock();
  if (!held.ok()) return error("taking the solver role", held.status);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (held.value && !stats_.solver && log_enabled(LogLevel::kInfo))
      std::fprintf(stderr, "loopd: fleet: vehicle %d solves the joint pose graph now\n", config_.vehicle);
    stats_.solver = held.value;
  }
  if (!held.value) return;
  const StoreResult<FleetCounts> counts = shared_->fleet_counts();
  if (!counts.ok()) return error("counting the map", counts.status);
  if (counts.value.keyframes == 0) return;
  // Between rounds a few new keyframes wait for the next solve; the last round solves for any new keyframe, so the
  // final trajectory covers all of them.
  const std::int64_t solve_every = last ? 1 : config_.solve_every_keyframes;
  if (solved_counts_ && counts.value.loops_accepted == solved_counts_->loops_accepted && counts.value.ledger_seq == solved_counts_->ledger_seq &&
      counts.value.keyframes - solved_counts_->keyframes < solve_every && counts.value.newest_revision == solved_counts_->newest_revision)
    return;
  std::vector<JointKeyframe> keyframes;
  std::vector<JointLoop> loops;
  if (const StoreStatus s = read_graph(*shared_, &keyframes, &loops); !s.ok()) return error("reading the pose graph", s);
  JointCorrectionConfig joint;
  joint.corrector = corrector_;
  const JointCorrection solved = solve_joint_correction(std::move(keyframes), loops, joint);
  if (!solved.ok) return;
  const StoreResult<std::int64_t> revision = shared_->put_fleet_correction(to_record(solved, config_.vehicle, solved.loops_used));
  if (!revision.ok()) return error("storing the joint correction", revision.status);
  solved_counts_ = counts.value;
  solved_counts_->newest_revision = revision.value;
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.solves;
}

void FleetSync::publish_newest() {
  const StoreResult<std::optional<FleetCorrectionRecord>> newest = shared_->fleet_correction(published_revision_);
  if (!newest.ok()) return error("reading the joint correction", newest.status);
  if (!newest.value) return;
  published_revision_ = newest.value->revision;
  publish_(to_correction_output(*newest.value, config_.vehicle));
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.revisions_published;
  stats_.newest_revision = published_revision_;
}

void FleetSync::error(const std::string& what, const StoreStatus& status) {
  ++round_errors_;
  std::int64_t n = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    n = ++stats_.errors;
    stats_.last_error = what + ": " + status.message;
  }
  if ((n == 1 || n % 100 == 0) && log_enabled(LogLevel::kWarn))
    std::fprintf(stderr, "loopd: fleet: %s: %s (%lld so far; tried again every %.1f s)\n", what.c_str(), status.message.c_str(),
                 static_cast<long long>(n), config_.poll_interval);
}

std::vector<KeyframeRecord> FleetSync::take_remote() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<KeyframeRecord> out;
  out.swap(inbox_);
  return out;
}

FleetStats FleetSync::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace loopd
