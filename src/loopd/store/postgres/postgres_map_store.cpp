#include "loopd/store/postgres/postgres_map_store.hpp"

#include <pqxx/pqxx>

#include <atomic>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <stdexcept>

#include "loopd/store/keyframe_codec.hpp"
#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/postgres/fleet_correction_blobs.hpp"
#include "loopd/store/postgres/postgres_connection.hpp"
#include "loopd/store/postgres/postgres_schema.hpp"
#include "loopd/store/record_blobs.hpp"
#include "loopd/store/shared_map.hpp"
#include "loopd/records/vehicle_sessions.hpp"

namespace loopd {
namespace {

using Code = StoreStatus::Code;
using postgres::Connection;
using Tx = pqxx::transaction_base;

constexpr int kKeptFleetRevisions = 20;  // joint corrections kept (a reader may still fetch one a little behind)
// Keyframes per read: ~100 KB each with the prepared scan (a batch of ~13 MB), ~2 KB each without.
constexpr std::size_t kFullKeyframeBatch = 128;
constexpr std::size_t kKeyframeBatch = 4096;

pqxx::binarystring bin(const std::vector<std::uint8_t>& v) { return pqxx::binarystring(v.data(), v.size()); }
std::vector<std::uint8_t> bytes_of(const pqxx::field& f) {
  const pqxx::binarystring b(f);
  return std::vector<std::uint8_t>(b.data(), b.data() + b.size());
}
double f64(const pqxx::field& f) { return f.is_null() ? std::nan("") : f.as<double>(); }
/// NaN as SQL NULL would need an optional; PostgreSQL's float8 holds NaN and infinities, written as text.
std::string f64_text(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Infinity" : "-Infinity";
  return pqxx::to_string(v);
}

/// @brief The session ids a store scoped to `vehicle` owns ([INT_MIN, INT_MAX] unscoped).
std::pair<long long, long long> session_range(int vehicle) {
  const SessionRange r = sessions_of(vehicle);
  return {static_cast<long long>(r.first), static_cast<long long>(r.last)};
}

class PostgresMapStore final : public MapStore, public SharedMap {
 public:
  PostgresMapStore(const MapStoreConfig& config)
      : connection_(config.uri, mask_password(config.uri), config.read_only, config.busy_timeout_ms),
        display_(mask_password(config.uri)),
        vehicle_(config.vehicle),
        read_only_(config.read_only) {}

  StoreStatus open();
  /// Asks the server for the database's size when kSizePeriod has passed since it last did (after a commit).
  void refresh_size();

  const std::string& uri() const override { return display_; }
  std::int64_t size_bytes() const override { return size_bytes_.load(); }
  StoreStatus begin() override { return connection_.begin(); }
  StoreStatus commit() override;
  StoreStatus rollback() override { return connection_.rollback(); }
  StoreStatus put_session(const SessionRecord& session) override;
  StoreResult<std::vector<SessionRecord>> sessions() override;
  StoreStatus put_keyframe(const MapKeyframe& keyframe) override;
  StoreStatus for_each_keyframe(std::optional<SessionId> session, KeyframeLoad load, const std::function<void(MapKeyframe&&)>& visit) override;
  StoreResult<PreparedScan> get_prepared(const KeyframeKey& key) override;
  StoreResult<PointCloud> get_map_cloud(const KeyframeKey& key) override;
  StoreStatus retire_keyframes(const std::vector<KeyframeKey>& keys) override;
  StoreStatus mark_decided(const KeyframeKey& key) override;
  StoreStatus mark_published(std::int64_t event_id) override;
  StoreResult<std::int64_t> drop_undecided() override;
  StoreStatus put_loop(const LoopDecision& loop) override;
  StoreStatus for_each_loop(bool accepted_only, const std::function<void(LoopDecision&&)>& visit) override;
  StoreResult<std::int64_t> put_ledger_entry(const LoopLedgerEntry& entry) override;
  StoreResult<std::vector<LoopLedgerEntry>> loop_ledger(std::int64_t after_seq) override;
  StoreStatus put_correction(const CorrectionRecord& correction) override;
  StoreResult<std::optional<CorrectionRecord>> correction() override;
  StoreResult<MapStats> stats() override;
  StoreStatus check() override;
  SharedMap* shared() override { return this; }

  StoreStatus for_each_new_remote_keyframe(std::map<SessionId, std::int64_t>& newest_seen, KeyframeLoad load,
                                           const std::function<void(MapKeyframe&&)>& visit) override;
  StoreResult<bool> hold_solver_lock() override;
  StoreStatus for_each_fleet_keyframe(const std::function<void(MapKeyframe&&)>& visit) override;
  StoreStatus for_each_fleet_loop(const std::function<void(LoopDecision&&)>& visit) override;
  StoreResult<FleetCounts> fleet_counts() override;
  StoreResult<std::int64_t> put_fleet_correction(const FleetCorrectionRecord& record) override;
  StoreResult<std::optional<FleetCorrectionRecord>> fleet_correction(std::int64_t after_revision) override;

 private:
  StoreStatus corrupt(const std::string& what) const { return {Code::kCorrupt, "map " + display_ + ": " + what}; }
  StoreStatus create_or_check_schema();
  StoreStatus read_keyframe(const pqxx::row& row, KeyframeLoad load, MapKeyframe& out) const;
  StoreStatus read_loop(const pqxx::row& row, LoopDecision& out) const;
  void same_keyframe_stored(Tx& t, const KeyframeRecord& r);
  void same_loop_stored(Tx& t, const LoopDecision& l);
  StoreStatus keyframes_where(const std::string& operation, KeyframeLoad load, const std::string& where,
                              const std::function<void(MapKeyframe&&)>& visit);
  StoreStatus loops_where(const std::string& operation, const std::function<pqxx::result(Tx&)>& query,
                          const std::function<void(LoopDecision&&)>& visit);
  int writer() const { return std::max(vehicle_, 0); }

  Connection connection_;
  std::string display_;
  int vehicle_;
  bool read_only_;
  std::atomic<std::int64_t> size_bytes_{0};  ///< pg_database_size, as last asked
  std::chrono::steady_clock::time_point size_asked_{};
};

constexpr std::chrono::seconds kSizePeriod{10};

StoreStatus PostgresMapStore::commit() {
  StoreStatus s = connection_.commit();
  if (s.ok()) refresh_size();
  return s;
}

void PostgresMapStore::refresh_size() {
  const auto now = std::chrono::steady_clock::now();
  if (size_asked_ != std::chrono::steady_clock::time_point{} && now - size_asked_ < kSizePeriod) return;
  size_asked_ = now;
  std::int64_t bytes = 0;
  const StoreStatus s =
      connection_.run("database size", [&](Tx& t) { bytes = t.exec1("SELECT pg_database_size(current_database())")[0].as<std::int64_t>(); });
  if (s.ok()) size_bytes_.store(bytes);
}

StoreStatus PostgresMapStore::open() {
  if (StoreStatus s = connection_.connect(); !s.ok()) return s;
  return create_or_check_schema();
}

StoreStatus PostgresMapStore::create_or_check_schema() {
  std::optional<std::string> version;
  StoreStatus s = connection_.run("read the schema version", [&](Tx& t) {
    if (!read_only_) t.exec_params("SELECT pg_advisory_xact_lock($1)", postgres::kSchemaLock);
    const pqxx::result exists = t.exec("SELECT to_regclass('loopd_meta') IS NOT NULL");
    if (exists[0][0].as<bool>()) {
      const pqxx::result v = t.exec("SELECT value FROM loopd_meta WHERE key = 'schema_version'");
      if (!v.empty()) version = v[0][0].as<std::string>();
      // An older schema this build knows is upgraded in place (under the schema lock; read-only: refused below).
      const int known = static_cast<int>(sizeof(postgres::kSchemaUpgrades) / sizeof(postgres::kSchemaUpgrades[0])) + 1;
      int from = 0;
      if (version) from = std::atoi(version->c_str());
      if (!read_only_ && from >= 1 && from < kPostgresMapSchemaVersion && kPostgresMapSchemaVersion <= known) {
        for (int step = from; step < kPostgresMapSchemaVersion; ++step) t.exec(postgres::kSchemaUpgrades[step - 1]);
        t.exec_params("UPDATE loopd_meta SET value = $1 WHERE key = 'schema_version'", std::to_string(kPostgresMapSchemaVersion));
        version = std::to_string(kPostgresMapSchemaVersion);
      }
      return;
    }
    if (read_only_) return;
    t.exec(postgres::kSchema);
    t.exec_params("INSERT INTO loopd_meta VALUES ('schema_version', $1)", std::to_string(kPostgresMapSchemaVersion));
    version = std::to_string(kPostgresMapSchemaVersion);
  });
  if (!s.ok()) return s;
  if (!version) return {read_only_ ? Code::kNotFound : Code::kCorrupt, "map " + display_ + " holds no loopd map (no table loopd_meta)"};
  if (*version != std::to_string(kPostgresMapSchemaVersion))
    return corrupt("has schema version " + *version + ", this loopd reads " + std::to_string(kPostgresMapSchemaVersion));
  return {};
}

// ---- sessions ----

StoreStatus PostgresMapStore::put_session(const SessionRecord& r) {
  return connection_.run("put session " + std::to_string(r.id), [&](Tx& t) {
    t.exec_params(
        "INSERT INTO sessions VALUES ($1, $2, $3, $4, $5, $6) ON CONFLICT (id) DO UPDATE SET first_utime = excluded.first_utime, "
        "sensor = excluded.sensor, source = excluded.source, T_map_session = excluded.T_map_session, anchored = excluded.anchored",
        r.id, r.first_utime, r.sensor, r.source, bin(blobs::pose_blob(r.T_map_session)), r.anchored);
  });
}

StoreResult<std::vector<SessionRecord>> PostgresMapStore::sessions() {
  StoreResult<std::vector<SessionRecord>> out;
  const std::pair<long long, long long> range = session_range(vehicle_);
  const long long lo = range.first, hi = range.second;
  std::optional<SessionId> bad_pose;
  out.status = connection_.run("read sessions", [&](Tx& t) {
    for (const pqxx::row& row : t.exec_params("SELECT id, first_utime, sensor, source, T_map_session, anchored FROM sessions "
                                              "WHERE id BETWEEN $1 AND $2 ORDER BY id",
                                              lo, hi)) {
      SessionRecord s;
      s.id = row[0].as<SessionId>();
      s.first_utime = row[1].as<std::int64_t>();
      s.sensor = row[2].as<std::string>();
      s.source = row[3].as<std::string>();
      const std::vector<std::uint8_t> pose = bytes_of(row[4]);
      if (pose.size() != blobs::kPoseBytes) {
        bad_pose = s.id;
        return;
      }
      s.T_map_session = blobs::read_pose(pose.data());
      s.anchored = row[5].as<bool>();
      out.value.push_back(std::move(s));
    }
  });
  if (out.ok() && bad_pose) out.status = corrupt("session " + std::to_string(*bad_pose) + ": T_map_session is not 96 bytes");
  return out;
}

// ---- keyframes ----

StoreStatus PostgresMapStore::put_keyframe(const MapKeyframe& keyframe) {
  const KeyframeRecord& r = keyframe.record;
  const KeyframeFeatures* f = r.features.get();
  const std::vector<std::uint8_t> descriptor = f ? encode_descriptor(f->descriptor) : std::vector<std::uint8_t>{};
  const std::vector<std::uint8_t> place = f && f->place.ok ? encode_place_descriptor(f->place) : std::vector<std::uint8_t>{};
  const std::vector<std::uint8_t> features = f ? encode_features(*f) : std::vector<std::uint8_t>{};
  const std::vector<std::uint8_t> step_bytes = r.step ? blobs::step_blob(*r.step) : std::vector<std::uint8_t>{};  // empty: NULL
  return connection_.run("put keyframe " + to_string(r.key), [&](Tx& t) {
    const pqxx::result inserted = t.exec_params(
        "INSERT INTO keyframes (" + std::string(postgres::kKeyframeColumns) +
            ", features) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, NULLIF($18, ''::bytea), $19) "
            "ON CONFLICT DO NOTHING",
        r.key.session, r.key.index, r.utime, bin(blobs::pose_blob(r.T_odom_sensor)), bin(blobs::pose_blob(keyframe.T_map_sensor)),
        f64_text(r.residual), f64_text(r.travelled), f != nullptr, f && f->ok, f ? f->error : std::string(),
        static_cast<std::int64_t>(f ? f->input_points : 0), static_cast<std::int64_t>(f ? f->invalid_points : 0),
        f64_text(f ? f->ms_descriptor : 0.0), f64_text(f ? f->ms_prepare : 0.0), bin(descriptor), bin(place),
        static_cast<std::int64_t>(r.scan_fingerprint), bin(step_bytes), bin(features));
    if (inserted.affected_rows() == 0) return same_keyframe_stored(t, r);  // with its map cloud: one transaction
    if (keyframe.map_cloud) {
      const std::vector<std::uint8_t>& blob = *keyframe.map_cloud;
      t.exec_params("INSERT INTO map_clouds VALUES ($1, $2, $3, $4)", r.key.session, r.key.index,
                    static_cast<std::int64_t>(map_cloud_blob_points(blob.data(), blob.size())), bin(blob));
    }
  });
}

StoreStatus PostgresMapStore::read_keyframe(const pqxx::row& row, KeyframeLoad load, MapKeyframe& out) const {
  KeyframeRecord& r = out.record;
  r.key = KeyframeKey{row[0].as<SessionId>(), row[1].as<std::int64_t>()};
  r.utime = row[2].as<std::int64_t>();
  const std::vector<std::uint8_t> odom = bytes_of(row[3]), map = bytes_of(row[4]);
  if (odom.size() != blobs::kPoseBytes || map.size() != blobs::kPoseBytes)
    return corrupt("keyframe " + to_string(r.key) + ": a pose is not 96 bytes");
  r.T_odom_sensor = blobs::read_pose(odom.data());
  out.T_map_sensor = blobs::read_pose(map.data());
  r.residual = f64(row[5]);
  r.travelled = f64(row[6]);
  r.scan_fingerprint = static_cast<std::uint64_t>(row[16].as<std::int64_t>());
  if (!row[17].is_null()) {
    const std::vector<std::uint8_t> step = bytes_of(row[17]);
    if (step.size() != blobs::kStepBytes)
      return corrupt("keyframe " + to_string(r.key) + ": its measured step is not " + std::to_string(blobs::kStepBytes) + " bytes");
    r.step = blobs::read_step(step.data());
  }
  out.retired = row[18].as<bool>();
  if (load == KeyframeLoad::kPose || !row[7].as<bool>()) return {};
  auto f = std::make_shared<KeyframeFeatures>();
  if (load == KeyframeLoad::kFull) {
    const std::vector<std::uint8_t> blob = bytes_of(row[19]);
    DecodedFeatures decoded = decode_features(blob);
    if (!decoded.ok) return corrupt("keyframe " + to_string(r.key) + ": " + decoded.error);
    *f = std::move(decoded.features);
  } else {
    f->ok = row[8].as<bool>();
    f->error = row[9].as<std::string>();
    f->input_points = row[10].as<std::size_t>();
    f->invalid_points = row[11].as<std::size_t>();
    f->ms_descriptor = f64(row[12]);
    f->ms_prepare = f64(row[13]);
  }
  const std::vector<std::uint8_t> descriptor = bytes_of(row[14]);
  DecodedDescriptor d = decode_descriptor(descriptor.data(), descriptor.size());
  if (!d.ok) return corrupt("keyframe " + to_string(r.key) + ": " + d.error);
  f->descriptor = std::move(d.descriptor);
  const std::vector<std::uint8_t> place = bytes_of(row[15]);
  if (!place.empty()) {
    DecodedPlaceDescriptor p = decode_place_descriptor(place.data(), place.size());
    if (!p.ok) return corrupt("keyframe " + to_string(r.key) + ": " + p.error);
    f->place = std::move(p.descriptor);
  }
  r.features = std::move(f);
  return {};
}

/// @brief Visits the keyframes `where` (SQL over keyframes' columns, numbers only) selects, in key order, as deep as
/// `load`: read in batches (a map's features do not fit in one result), each batch visited after its transaction so a
/// visitor may write.
StoreStatus PostgresMapStore::keyframes_where(const std::string& operation, KeyframeLoad load, const std::string& where,
                                              const std::function<void(MapKeyframe&&)>& visit) {
  const std::string columns = std::string(postgres::kKeyframeColumns) + ", retired" + (load == KeyframeLoad::kFull ? ", features" : "");
  const std::size_t batch = load == KeyframeLoad::kFull ? kFullKeyframeBatch : kKeyframeBatch;
  const std::string sql = "SELECT " + columns + " FROM keyframes WHERE (" + where +
                          ") AND (session, idx) > ($1::integer, $2::bigint) ORDER BY session, idx LIMIT " + std::to_string(batch);
  KeyframeKey after{std::numeric_limits<SessionId>::min(), std::numeric_limits<std::int64_t>::min()};
  for (;;) {
    std::vector<MapKeyframe> read;
    StoreStatus decoded;
    StoreStatus s = connection_.run(operation, [&](Tx& t) {
      for (const pqxx::row& row : t.exec_params(sql, after.session, after.index)) {
        MapKeyframe k;
        if (decoded = read_keyframe(row, load, k); !decoded.ok()) return;
        read.push_back(std::move(k));
      }
    });
    if (!s.ok()) return s;
    if (!decoded.ok()) return decoded;
    if (!read.empty()) after = read.back().record.key;
    for (MapKeyframe& k : read) visit(std::move(k));
    if (read.size() < batch) return {};
  }
}

StoreStatus PostgresMapStore::for_each_keyframe(std::optional<SessionId> session, KeyframeLoad load,
                                                const std::function<void(MapKeyframe&&)>& visit) {
  const std::pair<long long, long long> range = session_range(vehicle_);
  long long lo = range.first, hi = range.second;
  if (session) lo = hi = *session;
  return keyframes_where("read keyframes", load, "session BETWEEN " + std::to_string(lo) + " AND " + std::to_string(hi), visit);
}

StoreResult<PreparedScan> PostgresMapStore::get_prepared(const KeyframeKey& key) {
  StoreResult<PreparedScan> out;
  std::optional<bool> has_features;
  std::vector<std::uint8_t> blob;
  out.status = connection_.run("read keyframe " + to_string(key), [&](Tx& t) {
    const pqxx::result r = t.exec_params("SELECT has_features, features FROM keyframes WHERE session = $1 AND idx = $2", key.session, key.index);
    if (r.empty()) return;
    has_features = r[0][0].as<bool>();
    if (*has_features) blob = bytes_of(r[0][1]);
  });
  if (!out.ok()) return out;
  if (!has_features || !*has_features) {
    out.status = {Code::kNotFound,
                  "map " + display_ + (has_features ? ": keyframe " + to_string(key) + " has no features" : ": no keyframe " + to_string(key))};
    return out;
  }
  DecodedFeatures decoded = decode_features(blob);
  if (!decoded.ok)
    out.status = corrupt("keyframe " + to_string(key) + ": " + decoded.error);
  else
    out.value = std::move(decoded.features.prepared);
  return out;
}

StoreResult<PointCloud> PostgresMapStore::get_map_cloud(const KeyframeKey& key) {
  StoreResult<PointCloud> out;
  std::optional<std::vector<std::uint8_t>> blob;
  out.status = connection_.run("read the map cloud of keyframe " + to_string(key), [&](Tx& t) {
    const pqxx::result r = t.exec_params("SELECT cloud FROM map_clouds WHERE session = $1 AND idx = $2", key.session, key.index);
    if (!r.empty()) blob = bytes_of(r[0][0]);
  });
  if (!out.ok()) return out;
  if (!blob) {
    out.status = {Code::kNotFound, "map " + display_ + ": keyframe " + to_string(key) + " has no map cloud"};
    return out;
  }
  DecodedMapCloud decoded = decode_map_cloud(blob->data(), blob->size());
  if (!decoded.ok)
    out.status = corrupt("keyframe " + to_string(key) + ": " + decoded.error);
  else
    out.value = std::move(decoded.cloud);
  return out;
}

StoreStatus PostgresMapStore::retire_keyframes(const std::vector<KeyframeKey>& keys) {
  // This vehicle's keyframes only (its session range), all in one transaction.
  const std::pair<long long, long long> range = session_range(vehicle_);
  std::optional<KeyframeKey> missing;
  StoreStatus s = connection_.run("retire " + std::to_string(keys.size()) + " keyframes", [&, lo = range.first, hi = range.second](Tx& t) {
    missing.reset();
    // Every key first, so a refusal writes nothing (the caller's transaction may hold other writes).
    for (const KeyframeKey& key : keys) {
      if (t.exec_params("SELECT 1 FROM keyframes WHERE session = $1 AND idx = $2 AND session BETWEEN $3 AND $4", key.session, key.index, lo, hi)
              .empty()) {
        missing = key;
        return;
      }
    }
    for (const KeyframeKey& key : keys) {
      t.exec_params(
          "UPDATE keyframes SET retired = true, has_features = false, descriptor = ''::bytea, place = ''::bytea, features = ''::bytea "
          "WHERE session = $1 AND idx = $2",
          key.session, key.index);
      t.exec_params("DELETE FROM map_clouds WHERE session = $1 AND idx = $2", key.session, key.index);
    }
  });
  if (s.ok() && missing) return {Code::kNotFound, "map " + display_ + ": no keyframe " + to_string(*missing) + " of this vehicle to retire"};
  return s;
}

StoreStatus PostgresMapStore::mark_decided(const KeyframeKey& key) {
  std::size_t changed = 0;
  StoreStatus s = connection_.run("mark keyframe " + to_string(key) + " decided", [&](Tx& t) {
    changed = t.exec_params("UPDATE keyframes SET decided = true WHERE session = $1 AND idx = $2", key.session, key.index).affected_rows();
  });
  if (s.ok() && changed == 0) return {Code::kNotFound, "map " + display_ + ": no keyframe " + to_string(key) + " to mark decided"};
  return s;
}

StoreResult<std::int64_t> PostgresMapStore::drop_undecided() {
  // This vehicle's undecided keyframes, the decisions they made and a correction one of those made: all or nothing.
  StoreResult<std::int64_t> out;
  const std::pair<long long, long long> range = session_range(vehicle_);
  const long long lo = range.first, hi = range.second;
  out.status = connection_.run("drop undecided keyframes", [&, lo = lo, hi = hi](Tx& t) {
    const std::string undecided_query = "SELECT 1 FROM keyframes k WHERE k.session = l.query_session AND k.idx = l.query_idx AND NOT k.decided";
    // Unscoped (vehicle -1): every vehicle's.
    t.exec_params(
        "DELETE FROM correction c WHERE ($1 < 0 OR c.vehicle = $1) AND EXISTS (SELECT 1 FROM loops l WHERE l.vehicle = c.vehicle AND "
        "l.event_id = c.loop_event_id AND EXISTS (" +
            undecided_query + "))",
        vehicle_);
    t.exec_params("DELETE FROM loops l WHERE ($1 < 0 OR l.vehicle = $1) AND EXISTS (" + undecided_query + ")", vehicle_);
    out.value =
        static_cast<std::int64_t>(t.exec_params("DELETE FROM keyframes WHERE session BETWEEN $1 AND $2 AND NOT decided", lo, hi).affected_rows());
  });
  return out;
}

// ---- loops ----

StoreStatus PostgresMapStore::put_loop(const LoopDecision& l) {
  std::vector<std::uint8_t> information;
  blobs::append_doubles(information, l.information.data(), 36);
  return connection_.run("put loop event " + std::to_string(l.event_id), [&](Tx& t) {
    const pqxx::result inserted = t.exec_params(
        "INSERT INTO loops (vehicle, " + std::string(postgres::kLoopColumns) +
            ") VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20, $21, $22, $23, $24, false) "
            "ON CONFLICT DO NOTHING",
        writer(), l.event_id, l.query.session, l.query.index, l.match.session, l.match.index, l.query_utime, l.match_utime,
        int{status_code(l.status)}, l.stage, l.reason, f64_text(l.gate_distance), f64_text(l.gate_radius), f64_text(l.descriptor_distance),
        f64_text(l.lcp_fraction), f64_text(l.icp_residual), f64_text(l.icp_fitness), f64_text(l.hungarian_consistency), f64_text(l.degeneracy),
        bin(blobs::pose_blob(l.T_match_query)), bin(information), l.retrieval, f64_text(l.place_distance), l.confirmed);
    if (inserted.affected_rows() == 0) same_loop_stored(t, l);
  });
}

StoreStatus PostgresMapStore::mark_published(std::int64_t event_id) {
  return connection_.run("mark loop event " + std::to_string(event_id) + " published",
                         [&](Tx& t) { t.exec_params("UPDATE loops SET published = true WHERE vehicle = $1 AND event_id = $2", writer(), event_id); });
}

// A put that met its own key: a write retried after its COMMIT reached the server but the acknowledgement did not
// (the connection lost). The same content is success; other content is refused (and aborts an open transaction).
void PostgresMapStore::same_keyframe_stored(Tx& t, const KeyframeRecord& r) {
  const pqxx::result row =
      t.exec_params("SELECT utime, T_odom_sensor, scan_fingerprint FROM keyframes WHERE session = $1 AND idx = $2", r.key.session, r.key.index);
  if (!row.empty() && row[0][0].as<std::int64_t>() == r.utime && bytes_of(row[0][1]) == blobs::pose_blob(r.T_odom_sensor) &&
      static_cast<std::uint64_t>(row[0][2].as<std::int64_t>()) == r.scan_fingerprint)
    return;
  throw std::runtime_error("already stored with other content (another scan time, pose or scan fingerprint)");
}

void PostgresMapStore::same_loop_stored(Tx& t, const LoopDecision& l) {
  const pqxx::result row = t.exec_params(
      "SELECT query_session, query_idx, match_session, match_idx, status, T_match_query FROM loops WHERE vehicle = $1 AND event_id = $2", writer(),
      l.event_id);
  if (!row.empty() && row[0][0].as<std::int64_t>() == l.query.session && row[0][1].as<std::int64_t>() == l.query.index &&
      row[0][2].as<std::int64_t>() == l.match.session && row[0][3].as<std::int64_t>() == l.match.index &&
      row[0][4].as<int>() == status_code(l.status) && bytes_of(row[0][5]) == blobs::pose_blob(l.T_match_query))
    return;
  throw std::runtime_error("already stored with other content (other keyframes, status or transform)");
}

StoreStatus PostgresMapStore::read_loop(const pqxx::row& row, LoopDecision& l) const {
  l.event_id = row[0].as<std::int64_t>();
  l.query = KeyframeKey{row[1].as<SessionId>(), row[2].as<std::int64_t>()};
  l.match = KeyframeKey{row[3].as<SessionId>(), row[4].as<std::int64_t>()};
  l.query_utime = row[5].as<std::int64_t>();
  l.match_utime = row[6].as<std::int64_t>();
  if (!loop_status_from_code(row[7].as<int>(), &l.status)) return corrupt("loop event " + std::to_string(l.event_id) + ": unknown status");
  l.stage = row[8].as<std::string>();
  l.reason = row[9].as<std::string>();
  double* fields[] = {&l.gate_distance, &l.gate_radius, &l.descriptor_distance,   &l.lcp_fraction,
                      &l.icp_residual,  &l.icp_fitness, &l.hungarian_consistency, &l.degeneracy};
  for (int i = 0; i < 8; ++i) *fields[i] = f64(row[10 + i]);
  const std::vector<std::uint8_t> pose = bytes_of(row[18]), information = bytes_of(row[19]);
  if (pose.size() != blobs::kPoseBytes || information.size() != 36 * sizeof(double))
    return corrupt("loop event " + std::to_string(l.event_id) + ": T_match_query or information has the wrong size");
  l.T_match_query = blobs::read_pose(pose.data());
  std::memcpy(l.information.data(), information.data(), information.size());
  l.retrieval = row[20].as<std::string>();
  l.place_distance = f64(row[21]);
  l.confirmed = row[22].as<bool>();
  l.published = row[23].as<bool>();
  return {};
}

/// @brief Reads the loop rows a query returns and visits them in order (after the transaction: a visitor may write).
StoreStatus PostgresMapStore::loops_where(const std::string& operation, const std::function<pqxx::result(Tx&)>& query,
                                          const std::function<void(LoopDecision&&)>& visit) {
  std::vector<LoopDecision> loops;
  StoreStatus decoded;
  StoreStatus s = connection_.run(operation, [&](Tx& t) {
    for (const pqxx::row& row : query(t)) {
      LoopDecision l;
      if (decoded = read_loop(row, l); !decoded.ok()) return;
      loops.push_back(std::move(l));
    }
  });
  if (!s.ok()) return s;
  if (!decoded.ok()) return decoded;
  for (LoopDecision& l : loops) visit(std::move(l));
  return {};
}

StoreStatus PostgresMapStore::for_each_loop(bool accepted_only, const std::function<void(LoopDecision&&)>& visit) {
  return loops_where(
      "read loops",
      [&](Tx& t) {
        return t.exec_params("SELECT " + std::string(postgres::kLoopColumns) +
                                 " FROM loops WHERE ($1 < 0 OR vehicle = $1) AND (NOT $2 OR status = 1) ORDER BY vehicle, event_id",
                             vehicle_, accepted_only);
      },
      visit);
}

// ---- correction (this vehicle's detector) ----

StoreStatus PostgresMapStore::put_correction(const CorrectionRecord& c) {
  if (c.keys.size() != c.T_map_sensor.size()) return {Code::kInvalid, "map " + display_ + ": correction keys and poses differ in number"};
  std::vector<std::uint8_t> keys, poses;
  for (const KeyframeKey& k : c.keys) blobs::append_key(keys, k);
  for (const Eigen::Isometry3d& T : c.T_map_sensor) blobs::append_pose(poses, T);
  return connection_.run("put correction revision " + std::to_string(c.revision), [&](Tx& t) {
    t.exec_params(
        "INSERT INTO correction VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9) ON CONFLICT (vehicle) DO UPDATE SET revision = "
        "excluded.revision, loop_event_id = excluded.loop_event_id, method = excluded.method, T_map_odom = excluded.T_map_odom, "
        "keys = excluded.keys, poses = excluded.poses, corrector_state = excluded.corrector_state, ledger_seq = excluded.ledger_seq",
        writer(), c.revision, c.loop_event_id, c.method, bin(blobs::pose_blob(c.T_map_odom)), bin(keys), bin(poses), bin(c.corrector_state),
        c.ledger_seq);
  });
}

// ---- loop ledger ----

StoreResult<std::int64_t> PostgresMapStore::put_ledger_entry(const LoopLedgerEntry& e) {
  StoreResult<std::int64_t> out;
  const std::string what = std::string(e.revoked ? "revoke" : "restore") + " loop event " + std::to_string(e.event_id);
  std::string refused;
  out.status = connection_.run(what, [&](Tx& t) {
    refused.clear();  // a transaction tried again starts again
    // The loop's row is locked: two operators entering the same change at once cannot both pass the check.
    const pqxx::result loops =
        t.exec_params("SELECT vehicle, status FROM loops WHERE ($1 < 0 OR vehicle = $1) AND event_id = $2 FOR UPDATE", vehicle_, e.event_id);
    if (loops.empty()) {
      refused = "the map holds no such loop";
      return;
    }
    if (loops.size() > 1) {
      refused = "the vehicles' event ids overlap here (" + std::to_string(loops.size()) + " vehicles hold the event): open the map as one vehicle";
      return;
    }
    const int vehicle = loops[0][0].as<int>();
    if (loops[0][1].as<int>() != status_code(LoopStatus::kAccepted)) {
      refused = "the loop was not accepted (only accepted loops are revoked)";
      return;
    }
    const pqxx::result last =
        t.exec_params("SELECT revoked FROM loop_ledger WHERE vehicle = $1 AND event_id = $2 ORDER BY seq DESC LIMIT 1", vehicle, e.event_id);
    const bool revoked = !last.empty() && last[0][0].as<bool>();
    if (revoked == e.revoked) {
      refused = revoked ? "the loop is revoked already" : "the loop is not revoked";
      return;
    }
    out.value =
        t.exec_params1("INSERT INTO loop_ledger (vehicle, event_id, revoked, who, reason, utime) VALUES ($1, $2, $3, $4, $5, $6) RETURNING seq",
                       vehicle, e.event_id, e.revoked, e.who, e.reason, e.utime)[0]
            .as<std::int64_t>();
  });
  if (out.ok() && !refused.empty()) out.status = {Code::kInvalid, "map " + display_ + ": " + what + ": " + refused};
  return out;
}

StoreResult<std::vector<LoopLedgerEntry>> PostgresMapStore::loop_ledger(std::int64_t after_seq) {
  StoreResult<std::vector<LoopLedgerEntry>> out;
  out.status = connection_.run("read the loop ledger", [&](Tx& t) {
    out.value.clear();  // a retried transaction starts again
    const pqxx::result rows =
        t.exec_params("SELECT seq, event_id, revoked, who, reason, utime FROM loop_ledger WHERE ($1 < 0 OR vehicle = $1) AND seq > $2 ORDER BY seq",
                      vehicle_, after_seq);
    for (const pqxx::row& r : rows) {
      LoopLedgerEntry e;
      e.seq = r[0].as<std::int64_t>();
      e.event_id = r[1].as<std::int64_t>();
      e.revoked = r[2].as<bool>();
      e.who = r[3].as<std::string>();
      e.reason = r[4].as<std::string>();
      e.utime = r[5].as<std::int64_t>();
      out.value.push_back(std::move(e));
    }
  });
  return out;
}

StoreResult<std::optional<CorrectionRecord>> PostgresMapStore::correction() {
  StoreResult<std::optional<CorrectionRecord>> out;
  bool bad = false;
  out.status = connection_.run("read the correction", [&](Tx& t) {
    const pqxx::result r = t.exec_params(
        "SELECT revision, loop_event_id, method, T_map_odom, keys, poses, corrector_state, ledger_seq FROM correction WHERE vehicle = $1", writer());
    if (r.empty()) return;
    CorrectionRecord c;
    c.revision = r[0][0].as<std::int64_t>();
    c.loop_event_id = r[0][1].as<std::int64_t>();
    c.method = r[0][2].as<std::string>();
    const std::vector<std::uint8_t> T = bytes_of(r[0][3]), keys = bytes_of(r[0][4]), poses = bytes_of(r[0][5]);
    bad = T.size() != blobs::kPoseBytes || keys.size() % blobs::kKeyBytes != 0 || poses.size() != keys.size() / blobs::kKeyBytes * blobs::kPoseBytes;
    if (bad) return;
    c.T_map_odom = blobs::read_pose(T.data());
    for (std::size_t i = 0; i < keys.size() / blobs::kKeyBytes; ++i) {
      c.keys.push_back(blobs::read_key(keys.data() + i * blobs::kKeyBytes));
      c.T_map_sensor.push_back(blobs::read_pose(poses.data() + i * blobs::kPoseBytes));
    }
    c.corrector_state = bytes_of(r[0][6]);
    c.ledger_seq = r[0][7].as<std::int64_t>();
    out.value = std::move(c);
  });
  if (bad) out.status = corrupt("the correction's keys and poses have the wrong sizes");
  return out;
}

// ---- stats and check ----

StoreResult<MapStats> PostgresMapStore::stats() {
  StoreResult<MapStats> out;
  const std::pair<long long, long long> range = session_range(vehicle_);
  const long long lo = range.first, hi = range.second;
  out.status = connection_.run("count records", [&, lo = lo, hi = hi](Tx& t) {
    const pqxx::row r = t.exec_params1(
        "SELECT (SELECT count(*) FROM sessions WHERE id BETWEEN $1 AND $2), (SELECT count(*) FROM keyframes WHERE session BETWEEN $1 AND $2), "
        "(SELECT count(*) FROM loops WHERE ($3 < 0 OR vehicle = $3) AND status = 1), (SELECT count(*) FROM loops WHERE ($3 < 0 OR vehicle = $3) "
        "AND status <> 1), (SELECT count(*) FROM map_clouds WHERE session BETWEEN $1 AND $2), (SELECT coalesce(sum(points), 0) FROM map_clouds "
        "WHERE session BETWEEN $1 AND $2), (SELECT coalesce(sum(length(cloud)), 0) FROM map_clouds WHERE session BETWEEN $1 AND $2), "
        "pg_database_size(current_database()), (SELECT count(*) FROM loops l WHERE ($3 < 0 OR l.vehicle = $3) AND l.status = 1 AND "
        "(SELECT e.revoked FROM loop_ledger e WHERE e.vehicle = l.vehicle AND e.event_id = l.event_id ORDER BY e.seq DESC LIMIT 1)), "
        "(SELECT count(*) FROM keyframes WHERE session BETWEEN $1 AND $2 AND retired)",
        lo, hi, vehicle_);
    std::int64_t* fields[] = {&out.value.sessions,      &out.value.keyframes,        &out.value.loops_accepted,  &out.value.loops_rejected,
                              &out.value.map_clouds,    &out.value.map_cloud_points, &out.value.map_cloud_bytes, &out.value.bytes,
                              &out.value.loops_revoked, &out.value.keyframes_retired};
    for (int i = 0; i < 10; ++i) *fields[i] = r[i].as<std::int64_t>();
  });
  if (out.ok()) size_bytes_.store(out.value.bytes);
  return out;
}

StoreStatus PostgresMapStore::check() {
  // The map's invariants, as the SQLite map's check (the server checks its own pages; foreign keys tie keyframes to
  // sessions): every decision names stored keyframes, keys consecutive within a session, correction keys stored.
  std::vector<std::string> problems;
  const std::pair<long long, long long> range = session_range(vehicle_);
  const long long lo = range.first, hi = range.second;
  const std::string loop_names = "SELECT 'loop event ' || event_id || ' (vehicle ' || vehicle || ') names keyframe ' || ";
  const std::string loop_queries[] = {
      loop_names +
          "query_session || '/' || query_idx || ', which is not stored' FROM loops WHERE ($1 < 0 OR vehicle = $1) AND NOT EXISTS "
          "(SELECT 1 FROM keyframes WHERE session = query_session AND idx = query_idx) LIMIT 10",
      loop_names +
          "match_session || '/' || match_idx || ', which is not stored' FROM loops WHERE ($1 < 0 OR vehicle = $1) AND NOT EXISTS "
          "(SELECT 1 FROM keyframes WHERE session = match_session AND idx = match_idx) LIMIT 10",
  };
  const std::string indices_query =
      "SELECT 'session ' || session || ': keyframe indices are not 0..' || (count(*) - 1) || ' (min ' || min(idx) || ', max ' || max(idx) || ')' "
      "FROM keyframes WHERE session BETWEEN $1 AND $2 GROUP BY session HAVING min(idx) <> 0 OR max(idx) <> count(*) - 1 LIMIT 10";
  StoreStatus s = connection_.run("check the map", [&, lo = lo, hi = hi](Tx& t) {
    for (const std::string& sql : loop_queries)
      for (const pqxx::row& r : t.exec_params(sql, vehicle_)) problems.push_back(r[0].as<std::string>());
    for (const pqxx::row& r : t.exec_params(indices_query, lo, hi)) problems.push_back(r[0].as<std::string>());
  });
  if (!s.ok()) return s;
  const auto c = correction();
  if (!c.ok()) return c.status;
  if (c.value)
    s = connection_.run("check the correction's keyframes", [&](Tx& t) {
      for (const KeyframeKey& key : c.value->keys) {
        if (problems.size() >= 30) break;
        if (t.exec_params("SELECT 1 FROM keyframes WHERE session = $1 AND idx = $2", key.session, key.index).empty())
          problems.push_back("correction revision " + std::to_string(c.value->revision) + " names keyframe " + to_string(key) +
                             ", which is not stored");
      }
    });
  if (!s.ok()) return s;
  if (problems.empty()) return {};
  std::string message = "map " + display_ + " fails its check (" + std::to_string(problems.size()) + " problems):";
  for (std::size_t i = 0; i < problems.size() && i < 10; ++i) message += "\n  " + problems[i];
  return {Code::kCorrupt, message};
}

// ---- the fleet ----

StoreStatus PostgresMapStore::for_each_new_remote_keyframe(std::map<SessionId, std::int64_t>& newest_seen, KeyframeLoad load,
                                                           const std::function<void(MapKeyframe&&)>& visit) {
  const std::pair<long long, long long> range = session_range(vehicle_);
  const long long lo = range.first, hi = range.second;
  // Per session (few) its newest decided index: an index scan backwards from the session's newest keyframe, not a
  // scan of every keyframe of the fleet.
  std::map<SessionId, std::int64_t> newest_decided;
  StoreStatus s = connection_.run("read the other vehicles' sessions", [&, lo = lo, hi = hi](Tx& t) {
    for (const pqxx::row& r : t.exec_params("SELECT s.id, (SELECT max(k.idx) FROM keyframes k WHERE k.session = s.id AND k.decided) FROM sessions s "
                                            "WHERE s.id NOT BETWEEN $1 AND $2",
                                            lo, hi))
      if (!r[1].is_null()) newest_decided[r[0].as<SessionId>()] = r[1].as<std::int64_t>();
  });
  if (!s.ok()) return s;
  for (const auto& entry : newest_decided) {  // no structured bindings: lambdas below use them (C++17)
    const SessionId session = entry.first;
    const std::int64_t newest = entry.second;
    const auto seen = newest_seen.find(session);
    const std::int64_t after = seen == newest_seen.end() ? -1 : seen->second;
    if (newest <= after) continue;
    const std::string where =
        "decided AND session = " + std::to_string(session) + " AND idx > " + std::to_string(after) + " AND idx <= " + std::to_string(newest);
    s = keyframes_where("read session " + std::to_string(session), load, where, [&, session = session](MapKeyframe&& k) {
      newest_seen[session] = k.record.key.index;
      visit(std::move(k));
    });
    if (!s.ok()) return s;
  }
  return {};
}

StoreResult<bool> PostgresMapStore::hold_solver_lock() {
  // The server's own record of this connection's locks, not a flag of ours: a connection made again (or a server
  // restarted) holds nothing. An advisory bigint key shows in pg_locks as classid (high half) and objid (low half).
  StoreResult<bool> out;
  out.status = connection_.run("take the solver lock", [&](Tx& t) {
    out.value = t.exec_params1(
                     "SELECT CASE WHEN EXISTS (SELECT 1 FROM pg_locks WHERE locktype = 'advisory' AND pid = pg_backend_pid() AND granted AND "
                     "classid = ($1::bigint >> 32)::oid AND objid = ($1::bigint & 4294967295)::oid AND objsubid = 1) THEN true "
                     "ELSE pg_try_advisory_lock($1::bigint) END",
                     postgres::kSolverLock)[0]
                    .as<bool>();
  });
  return out;
}

StoreStatus PostgresMapStore::for_each_fleet_keyframe(const std::function<void(MapKeyframe&&)>& visit) {
  return keyframes_where("read the fleet's keyframes", KeyframeLoad::kPose, "decided", visit);
}

StoreStatus PostgresMapStore::for_each_fleet_loop(const std::function<void(LoopDecision&&)>& visit) {
  return loops_where(
      "read the fleet's loops",
      [](Tx& t) {
        return t.exec("SELECT " + std::string(postgres::kLoopColumns) +
                      " FROM loops l WHERE status = 1 AND EXISTS (SELECT 1 FROM keyframes q WHERE q.session = query_session AND q.idx = query_idx "
                      "AND q.decided) AND EXISTS (SELECT 1 FROM keyframes m WHERE m.session = match_session AND m.idx = match_idx AND m.decided) "
                      "AND NOT coalesce((SELECT e.revoked FROM loop_ledger e WHERE e.vehicle = l.vehicle AND e.event_id = l.event_id ORDER BY "
                      "e.seq DESC LIMIT 1), false) ORDER BY vehicle, event_id");
      },
      visit);
}

StoreResult<FleetCounts> PostgresMapStore::fleet_counts() {
  StoreResult<FleetCounts> out;
  out.status = connection_.run("count the fleet's map", [&](Tx& t) {
    const pqxx::row r = t.exec1(
        "SELECT (SELECT count(*) FROM keyframes WHERE decided), (SELECT count(*) FROM loops WHERE status = 1), "
        "(SELECT coalesce(max(revision), 0) FROM fleet_corrections), (SELECT coalesce(max(seq), 0) FROM loop_ledger)");
    out.value.keyframes = r[0].as<std::int64_t>();
    out.value.loops_accepted = r[1].as<std::int64_t>();
    out.value.newest_revision = r[2].as<std::int64_t>();
    out.value.ledger_seq = r[3].as<std::int64_t>();
  });
  return out;
}

StoreResult<std::int64_t> PostgresMapStore::put_fleet_correction(const FleetCorrectionRecord& c) {
  StoreResult<std::int64_t> out;
  const std::optional<postgres::FleetCorrectionBlobs> b = postgres::encode_fleet_correction(c);
  if (!b) {
    out.status = {Code::kInvalid, "map " + display_ + ": joint correction keys, poses and scan times differ in number"};
    return out;
  }
  out.status = connection_.run("store the joint correction", [&](Tx& t) {
    t.exec_params("SELECT pg_advisory_xact_lock($1)", postgres::kRevisionLock);
    out.value = t.exec1("SELECT coalesce(max(revision), 0) + 1 FROM fleet_corrections")[0].as<std::int64_t>();
    t.exec_params("INSERT INTO fleet_corrections VALUES ($1, $2, $3, $4, $5, $6, $7, $8)", out.value, c.solver_vehicle, c.loops, c.solved_utime,
                  bin(b->keys), bin(b->poses), bin(b->utimes), bin(b->sessions));
    t.exec_params("DELETE FROM fleet_corrections WHERE revision <= $1::bigint - $2::bigint", out.value, kKeptFleetRevisions);
  });
  return out;
}

StoreResult<std::optional<FleetCorrectionRecord>> PostgresMapStore::fleet_correction(std::int64_t after_revision) {
  StoreResult<std::optional<FleetCorrectionRecord>> out;
  std::optional<std::string> bad;
  out.status = connection_.run("read the joint correction", [&](Tx& t) {
    const pqxx::result r = t.exec_params(
        "SELECT revision, solver_vehicle, loops, solved_utime, keys, poses, utimes, sessions FROM fleet_corrections WHERE revision > $1 "
        "ORDER BY revision DESC LIMIT 1",
        after_revision);
    if (r.empty()) return;
    FleetCorrectionRecord c;
    c.revision = r[0][0].as<std::int64_t>();
    c.solver_vehicle = r[0][1].as<int>();
    c.loops = r[0][2].as<std::int64_t>();
    c.solved_utime = r[0][3].as<std::int64_t>();
    const postgres::FleetCorrectionBlobs b{bytes_of(r[0][4]), bytes_of(r[0][5]), bytes_of(r[0][6]), bytes_of(r[0][7])};
    if ((bad = postgres::decode_fleet_correction(b, c))) return;
    out.value = std::move(c);
  });
  if (out.ok() && bad) out.status = corrupt("joint correction: " + *bad);
  return out;
}

}  // namespace

std::string mask_password(const std::string& uri) {
  // postgresql://user:password@host...: the part between the first ':' after the scheme and the '@' (an '@' in a
  // password is written %40, so the last '@' before the path ends the user info); and a ?password= / &password= value.
  std::string out = uri;
  const auto scheme = out.find("://");
  if (scheme == std::string::npos) return out;
  const auto path = out.find_first_of("/?", scheme + 3);
  const auto at = out.rfind('@', path == std::string::npos ? std::string::npos : path);
  const auto colon = out.find(':', scheme + 3);
  if (at != std::string::npos && at > scheme && colon != std::string::npos && colon < at) out = out.substr(0, colon + 1) + "***" + out.substr(at);
  for (const char* key : {"?password=", "&password="}) {
    const auto p = out.find(key);
    if (p == std::string::npos) continue;
    const auto value = p + std::strlen(key);
    out = out.substr(0, value) + "***" + out.substr(std::min(out.find('&', value), out.size()));
  }
  return out;
}

OpenedMapStore open_postgres_map_store(const MapStoreConfig& config) {
  OpenedMapStore out;
  if (config.vehicle < -1 || config.vehicle > kMaxVehicle) {
    out.status = {Code::kInvalid, "map " + mask_password(config.uri) + ": vehicle " + std::to_string(config.vehicle) + " is not -1 .. " +
                                      std::to_string(kMaxVehicle)};
    return out;
  }
  auto store = std::make_unique<PostgresMapStore>(config);
  out.status = store->open();
  if (!out.status.ok()) return out;
  store->refresh_size();
  out.store = std::move(store);
  return out;
}

namespace {
// The back end registers itself for "postgresql://" and "postgres://" URIs (store_uri.hpp); libpq reads the whole URI.
const bool registered = register_map_store_backend({"postgresql", "PostgreSQL server (a fleet map: several writers)", true,
                                                    [](const MapStoreConfig& c, const std::string&) { return open_postgres_map_store(c); }});
}  // namespace

}  // namespace loopd
