#include "loopd/store/sqlite/sqlite_map_store.hpp"

#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <fstream>
#include <sys/stat.h>

#include "loopd/store/keyframe_codec.hpp"
#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/record_blobs.hpp"
#include "loopd/store/store_uri.hpp"

namespace loopd {
namespace {

using Code = StoreStatus::Code;

/// @brief The SQLite result code's class as the engine must act on it.
Code code_of(int rc) {
  switch (rc & 0xff) {
    case SQLITE_OK:
    case SQLITE_ROW:
    case SQLITE_DONE:
      return Code::kOk;
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Code::kBusy;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
    case SQLITE_FORMAT:
      return Code::kCorrupt;
    case SQLITE_FULL:
    case SQLITE_IOERR:
    case SQLITE_READONLY:
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
    case SQLITE_NOMEM:
      return Code::kIo;
    case SQLITE_NOTFOUND:
      return Code::kNotFound;
    default:
      return Code::kInvalid;  // SQLITE_CONSTRAINT (a duplicate key, an unknown session), SQLITE_MISUSE, ...
  }
}

using blobs::append_doubles;
using blobs::append_key;
using blobs::append_pose;
using blobs::kKeyBytes;
using blobs::kPoseBytes;
using blobs::pose_blob;
using blobs::read_key;
using blobs::read_pose;

/// @brief One prepared statement, kept for the store's life; reset after every use by the Use guard.
class Statement {
 public:
  Statement() = default;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement() { sqlite3_finalize(stmt_); }
  int prepare(sqlite3* db, const char* sql) { return sqlite3_prepare_v3(db, sql, -1, SQLITE_PREPARE_PERSISTENT, &stmt_, nullptr); }
  sqlite3_stmt* get() const { return stmt_; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

/// @brief Binds values to a cached statement, steps it and resets it (also when a visitor throws).
class Use {
 public:
  explicit Use(Statement& s) : s_(s.get()) {}
  Use(const Use&) = delete;
  Use& operator=(const Use&) = delete;
  ~Use() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }
  Use& i64(std::int64_t v) {
    bind_rc(sqlite3_bind_int64(s_, ++n_, v));
    return *this;
  }
  Use& f64(double v) {
    bind_rc(sqlite3_bind_double(s_, ++n_, v));
    return *this;
  }
  Use& text(const std::string& v) {
    bind_rc(sqlite3_bind_text(s_, ++n_, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Use& blob(const std::vector<std::uint8_t>& v) {
    bind_rc(sqlite3_bind_blob(s_, ++n_, v.empty() ? "" : static_cast<const void*>(v.data()), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Use& null() {
    bind_rc(sqlite3_bind_null(s_, ++n_));
    return *this;
  }
  int step() { return bind_rc_ != SQLITE_OK ? bind_rc_ : sqlite3_step(s_); }

  std::int64_t i64_at(int c) const { return sqlite3_column_int64(s_, c); }
  /// NULL reads as NaN (SQLite stores a NaN double as NULL).
  double f64_at(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL ? std::nan("") : sqlite3_column_double(s_, c); }
  std::string text_at(int c) const {
    const auto* p = sqlite3_column_text(s_, c);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(s_, c))) : std::string();
  }
  const std::uint8_t* blob_at(int c, std::size_t& size) const {
    const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(s_, c));
    size = static_cast<std::size_t>(sqlite3_column_bytes(s_, c));
    return p;
  }
  bool is_null(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL; }

 private:
  void bind_rc(int rc) {
    if (rc != SQLITE_OK && bind_rc_ == SQLITE_OK) bind_rc_ = rc;
  }
  sqlite3_stmt* s_;
  int n_ = 0;
  int bind_rc_ = SQLITE_OK;
};

const char* const kSchema = R"sql(
CREATE TABLE sessions (
  id INTEGER PRIMARY KEY,
  first_utime INTEGER NOT NULL,
  sensor TEXT NOT NULL,
  source TEXT NOT NULL,
  T_map_session BLOB NOT NULL,
  anchored INTEGER NOT NULL
);
CREATE TABLE keyframes (
  session INTEGER NOT NULL REFERENCES sessions(id),
  idx INTEGER NOT NULL,
  utime INTEGER NOT NULL,
  T_odom_sensor BLOB NOT NULL,
  T_map_sensor BLOB NOT NULL,
  residual REAL,
  travelled REAL,
  decided INTEGER NOT NULL DEFAULT 0,
  has_features INTEGER NOT NULL,
  features_ok INTEGER NOT NULL,
  features_error TEXT NOT NULL,
  input_points INTEGER NOT NULL,
  invalid_points INTEGER NOT NULL,
  ms_descriptor REAL,
  ms_prepare REAL,
  descriptor BLOB,
  features BLOB,
  place BLOB,
  scan_fingerprint INTEGER NOT NULL DEFAULT 0,
  step BLOB,
  retired INTEGER NOT NULL DEFAULT 0,
  PRIMARY KEY (session, idx)
);
CREATE INDEX keyframes_undecided ON keyframes (session, idx) WHERE decided = 0;
CREATE TABLE loops (
  event_id INTEGER PRIMARY KEY,
  query_session INTEGER NOT NULL,
  query_idx INTEGER NOT NULL,
  match_session INTEGER NOT NULL,
  match_idx INTEGER NOT NULL,
  query_utime INTEGER NOT NULL,
  match_utime INTEGER NOT NULL,
  status INTEGER NOT NULL,
  stage TEXT NOT NULL,
  reason TEXT NOT NULL,
  gate_distance REAL, gate_radius REAL, descriptor_distance REAL, lcp_fraction REAL, icp_residual REAL,
  icp_fitness REAL, hungarian_consistency REAL, degeneracy REAL,
  T_match_query BLOB NOT NULL,
  information BLOB NOT NULL,
  retrieval TEXT NOT NULL DEFAULT 'gate',
  place_distance REAL NOT NULL DEFAULT -1,
  confirmed INTEGER NOT NULL DEFAULT 0,
  published INTEGER NOT NULL DEFAULT 1
);
CREATE INDEX loops_by_status ON loops (status, event_id);
CREATE TABLE map_clouds (
  session INTEGER NOT NULL,
  idx INTEGER NOT NULL,
  points INTEGER NOT NULL,
  cloud BLOB NOT NULL,
  PRIMARY KEY (session, idx),
  FOREIGN KEY (session, idx) REFERENCES keyframes (session, idx) ON DELETE CASCADE
);
CREATE TABLE correction (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  revision INTEGER NOT NULL,
  loop_event_id INTEGER NOT NULL,
  method TEXT NOT NULL,
  T_map_odom BLOB NOT NULL,
  keys BLOB NOT NULL,
  poses BLOB NOT NULL,
  corrector_state BLOB NOT NULL,
  ledger_seq INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE loop_ledger (
  seq INTEGER PRIMARY KEY,
  event_id INTEGER NOT NULL,
  revoked INTEGER NOT NULL,
  who TEXT NOT NULL,
  reason TEXT NOT NULL,
  utime INTEGER NOT NULL
);
CREATE INDEX loop_ledger_by_event ON loop_ledger (event_id, seq);
)sql";

// Keyframe columns shared by the two bulk reads; the full read adds `features` (last: reading the others never walks
// the features blob's overflow pages).
#define LOOPD_KEYFRAME_COLUMNS                                                                                                       \
  "session, idx, utime, T_odom_sensor, T_map_sensor, residual, travelled, has_features, features_ok, features_error, input_points, " \
  "invalid_points, ms_descriptor, ms_prepare, descriptor, place, scan_fingerprint, step, retired"

/// @brief The SQLite map: one connection, its cached statements, and the file name for messages.
class SqliteMapStore final : public MapStore {
 public:
  SqliteMapStore(sqlite3* db, std::string uri, std::string path) : db_(db), uri_(std::move(uri)), path_(std::move(path)) {}
  ~SqliteMapStore() override {
    statements_.clear();
    sqlite3_close_v2(db_);
  }

  StoreStatus setup(const MapStoreConfig& config);

  const std::string& uri() const override { return uri_; }
  std::int64_t size_bytes() const override;
  StoreStatus begin() override { return exec("BEGIN IMMEDIATE", "begin"); }
  StoreStatus commit() override { return exec("COMMIT", "commit"); }
  StoreStatus rollback() override { return exec("ROLLBACK", "rollback"); }
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

 private:
  enum Stmt {
    kPutSession,
    kSessions,
    kPutKeyframe,
    kKeyframes,
    kKeyframesFull,
    kPrepared,
    kPutMapCloud,
    kMapCloud,
    kHasKeyframe,
    kMarkDecided,
    kPutLoop,
    kLoops,
    kPutCorrection,
    kCorrection,
    kStoredKeyframe,
    kStoredLoop,
    kMarkPublished,
    kPutLedger,
    kLedger,
    kLoopState,
    kRetireKeyframe,
    kDeleteMapCloud,
    kCount
  };

  StoreStatus fail(int rc, const std::string& operation) const {
    return {code_of(rc), "map " + path_ + ": " + operation + ": " + sqlite3_errstr(rc) + " (" + sqlite3_errmsg(db_) + ")"};
  }
  StoreStatus corrupt(const std::string& what) const { return {Code::kCorrupt, "map " + path_ + ": " + what}; }
  StoreStatus exec(const char* sql, const std::string& operation) {
    const int rc = sqlite3_exec(db_, sql, nullptr, nullptr, nullptr);
    return rc == SQLITE_OK ? StoreStatus{} : fail(rc, operation);
  }
  /// Runs a write statement to SQLITE_DONE.
  StoreStatus done(Use& use, const std::string& operation) {
    const int rc = use.step();
    return rc == SQLITE_DONE ? StoreStatus{} : fail(rc, operation);
  }
  StoreResult<std::int64_t> scalar(const char* sql, const std::string& operation);
  StoreStatus insert_keyframe(const MapKeyframe& keyframe, bool* stored_before = nullptr);
  /// A put that hit its own primary key: success when the stored row has the same content (a write retried after
  /// its commit went through), else kInvalid naming what differs.
  StoreStatus same_keyframe_stored(const KeyframeRecord& r, const StoreStatus& refused);
  StoreStatus same_loop_stored(const LoopDecision& l, const StoreStatus& refused);
  StoreStatus upgrade_schema(std::int64_t from);
  StoreStatus read_keyframe(const Use& row, KeyframeLoad load, MapKeyframe& out) const;
  StoreStatus read_loop(const Use& row, LoopDecision& out) const;
  StoreStatus read_correction(const Use& row, CorrectionRecord& out) const;
  StoreStatus create_or_check_schema();
  std::vector<std::string> invariant_problems();

  sqlite3* db_;
  std::string uri_, path_;
  std::vector<std::unique_ptr<Statement>> statements_;
  Statement& stmt(Stmt s) { return *statements_[static_cast<std::size_t>(s)]; }
};

const char* sql_of(int s) {
  static const char* const kSql[] = {
      ("INSERT INTO sessions (id, first_utime, sensor, source, T_map_session, anchored) VALUES (?, ?, ?, ?, ?, ?) "
       "ON CONFLICT (id) DO UPDATE SET first_utime = excluded.first_utime, sensor = excluded.sensor, source = excluded.source, "
       "T_map_session = excluded.T_map_session, anchored = excluded.anchored"),
      "SELECT id, first_utime, sensor, source, T_map_session, anchored FROM sessions ORDER BY id",
      "INSERT INTO keyframes (" LOOPD_KEYFRAME_COLUMNS ", features) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
      "SELECT " LOOPD_KEYFRAME_COLUMNS " FROM keyframes WHERE ?1 IS NULL OR session = ?1 ORDER BY session, idx",
      "SELECT " LOOPD_KEYFRAME_COLUMNS ", features FROM keyframes WHERE ?1 IS NULL OR session = ?1 ORDER BY session, idx",
      "SELECT has_features, features FROM keyframes WHERE session = ? AND idx = ?",
      "INSERT INTO map_clouds (session, idx, points, cloud) VALUES (?, ?, ?, ?)",
      "SELECT cloud FROM map_clouds WHERE session = ? AND idx = ?",
      "SELECT 1 FROM keyframes WHERE session = ? AND idx = ?",
      "UPDATE keyframes SET decided = 1 WHERE session = ? AND idx = ?",
      "INSERT INTO loops VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 0)",
      "SELECT * FROM loops WHERE ?1 = 0 OR status = 1 ORDER BY event_id",
      ("INSERT OR REPLACE INTO correction (id, revision, loop_event_id, method, T_map_odom, keys, poses, corrector_state, ledger_seq) "
       "VALUES (1, ?, ?, ?, ?, ?, ?, ?, ?)"),
      "SELECT revision, loop_event_id, method, T_map_odom, keys, poses, corrector_state, ledger_seq FROM correction WHERE id = 1",
      "SELECT utime, T_odom_sensor, scan_fingerprint FROM keyframes WHERE session = ? AND idx = ?",
      "SELECT query_session, query_idx, match_session, match_idx, status, T_match_query FROM loops WHERE event_id = ?",
      "UPDATE loops SET published = 1 WHERE event_id = ?",
      "INSERT INTO loop_ledger (event_id, revoked, who, reason, utime) VALUES (?, ?, ?, ?, ?)",
      "SELECT seq, event_id, revoked, who, reason, utime FROM loop_ledger WHERE seq > ? ORDER BY seq",
      ("SELECT l.status, (SELECT e.revoked FROM loop_ledger e WHERE e.event_id = l.event_id ORDER BY e.seq DESC LIMIT 1) "
       "FROM loops l WHERE l.event_id = ?"),
      ("UPDATE keyframes SET retired = 1, has_features = 0, descriptor = NULL, place = NULL, features = NULL "
       "WHERE session = ? AND idx = ?"),
      "DELETE FROM map_clouds WHERE session = ? AND idx = ?",
  };
  return kSql[s];
}

StoreResult<std::int64_t> SqliteMapStore::scalar(const char* sql, const std::string& operation) {
  StoreResult<std::int64_t> out;
  Statement st;
  int rc = st.prepare(db_, sql);
  if (rc == SQLITE_OK) {
    Use use(st);
    rc = use.step();
    if (rc == SQLITE_ROW) {
      out.value = use.i64_at(0);
      return out;
    }
  }
  out.status = fail(rc, operation);
  return out;
}

StoreStatus SqliteMapStore::create_or_check_schema() {
  const auto version = scalar("PRAGMA user_version", "read the schema version");
  if (!version.ok()) return version.status;
  if (version.value == kSqliteMapSchemaVersion) return {};
  if (version.value >= 1 && version.value < kSqliteMapSchemaVersion && sqlite3_db_readonly(db_, "main") != 1) return upgrade_schema(version.value);
  if (version.value != 0) {
    return {Code::kCorrupt, "map " + path_ + " has schema version " + std::to_string(version.value) + ", this loopd reads " +
                                std::to_string(kSqliteMapSchemaVersion)};
  }
  const auto objects = scalar("SELECT count(*) FROM sqlite_master", "read the schema");
  if (!objects.ok()) return objects.status;
  if (objects.value != 0)
    return corrupt("is an SQLite database but not a loopd map (schema version 0, " + std::to_string(objects.value) + " tables)");
  if (sqlite3_db_readonly(db_, "main") == 1) return {Code::kNotFound, "map " + path_ + " is empty (opened read-only, so no map was created)"};
  if (auto st = exec("BEGIN IMMEDIATE", "create the schema"); !st.ok()) return st;
  const std::string create = std::string(kSchema) + "PRAGMA user_version = " + std::to_string(kSqliteMapSchemaVersion) + ";";
  if (auto st = exec(create.c_str(), "create the schema"); !st.ok()) {
    exec("ROLLBACK", "create the schema");
    return st;
  }
  return exec("COMMIT", "create the schema");
}

StoreStatus SqliteMapStore::upgrade_schema(std::int64_t from) {
  // 1 -> 2: the place descriptor (keyframes stored before it have none: not found by global retrieval) and how each
  // loop was found. 2 -> 3: the keyframes' map clouds (keyframes stored before have none: left out of the 3D map).
  // 3 -> 4: the keyframes' scan fingerprints (0 before: a replay resume matches those by time and pose alone) and
  // whether each decision reached the bus (decisions stored before were). 4 -> 5: the keyframes' steps measured by the
  // scans (none before: the corrections use the odometry's steps there, as when they were made). 5 -> 6: the loop
  // ledger (empty before) and the ledger entry each correction accounts for. 6 -> 7: retired keyframes (none before).
  const char* const steps[] = {
      "",
      ("ALTER TABLE keyframes ADD COLUMN place BLOB; ALTER TABLE loops ADD COLUMN retrieval TEXT NOT NULL DEFAULT 'gate'; "
       "ALTER TABLE loops ADD COLUMN place_distance REAL NOT NULL DEFAULT -1; ALTER TABLE loops ADD COLUMN confirmed INTEGER NOT NULL DEFAULT 0;"),
      ("CREATE TABLE map_clouds (session INTEGER NOT NULL, idx INTEGER NOT NULL, points INTEGER NOT NULL, cloud BLOB NOT NULL, "
       "PRIMARY KEY (session, idx), FOREIGN KEY (session, idx) REFERENCES keyframes (session, idx) ON DELETE CASCADE);"),
      "ALTER TABLE keyframes ADD COLUMN scan_fingerprint INTEGER NOT NULL DEFAULT 0; ALTER TABLE loops ADD COLUMN published INTEGER NOT NULL DEFAULT "
      "1;",
      "ALTER TABLE keyframes ADD COLUMN step BLOB;",
      ("ALTER TABLE correction ADD COLUMN ledger_seq INTEGER NOT NULL DEFAULT 0; CREATE TABLE loop_ledger (seq INTEGER PRIMARY KEY, "
       "event_id INTEGER NOT NULL, revoked INTEGER NOT NULL, who TEXT NOT NULL, reason TEXT NOT NULL, utime INTEGER NOT NULL); "
       "CREATE INDEX loop_ledger_by_event ON loop_ledger (event_id, seq);"),
      "ALTER TABLE keyframes ADD COLUMN retired INTEGER NOT NULL DEFAULT 0;",
  };
  std::string sql = "BEGIN IMMEDIATE;";
  for (std::int64_t v = from; v < kSqliteMapSchemaVersion; ++v) sql += steps[v];
  sql += " PRAGMA user_version = " + std::to_string(kSqliteMapSchemaVersion) + "; COMMIT;";
  const StoreStatus st = exec(sql.c_str(), "upgrade the schema " + std::to_string(from) + " -> " + std::to_string(kSqliteMapSchemaVersion));
  if (!st.ok()) exec("ROLLBACK", "upgrade the schema");
  return st;
}

StoreStatus SqliteMapStore::setup(const MapStoreConfig& config) {
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, config.busy_timeout_ms);
  // The version first: a map of another version is refused before anything is written to it.
  if (auto st = create_or_check_schema(); !st.ok()) return st;
  if (!config.read_only && path_ != ":memory:") {
    if (auto st = exec("PRAGMA journal_mode = WAL", "set the WAL journal"); !st.ok()) return st;
  }
  const std::string pragmas =
      std::string("PRAGMA synchronous = ") + (config.synchronous == "full" ? "FULL" : "NORMAL") + "; PRAGMA foreign_keys = ON;";
  if (auto st = exec(pragmas.c_str(), "set synchronous and foreign keys"); !st.ok()) return st;
  if (config.max_pages > 0) {
    const std::string cap = "PRAGMA max_page_count = " + std::to_string(config.max_pages);
    if (auto st = exec(cap.c_str(), "set max_page_count"); !st.ok()) return st;
  }
  for (int s = 0; s < kCount; ++s) {
    statements_.push_back(std::make_unique<Statement>());
    if (const int rc = statements_.back()->prepare(db_, sql_of(s)); rc != SQLITE_OK) return fail(rc, std::string("prepare ") + sql_of(s));
  }
  return {};
}

// ---- sessions ----

StoreStatus SqliteMapStore::put_session(const SessionRecord& session) {
  Use use(stmt(kPutSession));
  use.i64(session.id)
      .i64(session.first_utime)
      .text(session.sensor)
      .text(session.source)
      .blob(pose_blob(session.T_map_session))
      .i64(session.anchored ? 1 : 0);
  return done(use, "put session " + std::to_string(session.id));
}

StoreResult<std::vector<SessionRecord>> SqliteMapStore::sessions() {
  StoreResult<std::vector<SessionRecord>> out;
  Use use(stmt(kSessions));
  int rc;
  while ((rc = use.step()) == SQLITE_ROW) {
    SessionRecord s;
    s.id = static_cast<SessionId>(use.i64_at(0));
    s.first_utime = use.i64_at(1);
    s.sensor = use.text_at(2);
    s.source = use.text_at(3);
    std::size_t n = 0;
    const std::uint8_t* pose = use.blob_at(4, n);
    if (n != kPoseBytes) {
      out.status =
          corrupt("session " + std::to_string(s.id) + ": T_map_session is " + std::to_string(n) + " bytes, not " + std::to_string(kPoseBytes));
      return out;
    }
    s.T_map_session = read_pose(pose);
    s.anchored = use.i64_at(5) != 0;
    out.value.push_back(std::move(s));
  }
  if (rc != SQLITE_DONE) out.status = fail(rc, "read sessions");
  return out;
}

// ---- keyframes ----

StoreStatus SqliteMapStore::put_keyframe(const MapKeyframe& keyframe) {
  if (!keyframe.map_cloud) return insert_keyframe(keyframe);
  // The keyframe and its map cloud together (a savepoint nests in the caller's transaction when there is one).
  if (auto st = exec("SAVEPOINT put_keyframe", "put keyframe"); !st.ok()) return st;
  bool stored_before = false;
  StoreStatus st = insert_keyframe(keyframe, &stored_before);
  if (st.ok() && !stored_before) {
    const auto& blob = *keyframe.map_cloud;
    const auto points = static_cast<std::int64_t>(map_cloud_blob_points(blob.data(), blob.size()));
    Use use(stmt(kPutMapCloud));
    use.i64(keyframe.record.key.session).i64(keyframe.record.key.index).i64(points).blob(blob);
    st = done(use, "put the map cloud of keyframe " + to_string(keyframe.record.key));
  }
  if (!st.ok()) {
    exec("ROLLBACK TO put_keyframe", "put keyframe");
    exec("RELEASE put_keyframe", "put keyframe");
    return st;
  }
  return exec("RELEASE put_keyframe", "put keyframe");
}

StoreStatus SqliteMapStore::insert_keyframe(const MapKeyframe& keyframe, bool* stored_before) {
  const KeyframeRecord& r = keyframe.record;
  const KeyframeFeatures* f = r.features.get();
  Use use(stmt(kPutKeyframe));
  use.i64(r.key.session).i64(r.key.index).i64(r.utime).blob(pose_blob(r.T_odom_sensor)).blob(pose_blob(keyframe.T_map_sensor));
  use.f64(r.residual).f64(r.travelled).i64(f ? 1 : 0);
  if (f) {
    use.i64(f->ok ? 1 : 0).text(f->error).i64(static_cast<std::int64_t>(f->input_points)).i64(static_cast<std::int64_t>(f->invalid_points));
    use.f64(f->ms_descriptor).f64(f->ms_prepare).blob(encode_descriptor(f->descriptor));
    if (f->place.ok)
      use.blob(encode_place_descriptor(f->place));
    else
      use.null();
    use.i64(static_cast<std::int64_t>(r.scan_fingerprint));
  } else {
    use.i64(0).text("").i64(0).i64(0).f64(0.0).f64(0.0).null().null().i64(static_cast<std::int64_t>(r.scan_fingerprint));
  }
  if (r.step)
    use.blob(blobs::step_blob(*r.step));
  else
    use.null();
  use.i64(0);  // retired: never when written
  if (f)
    use.blob(encode_features(*f));
  else
    use.null();
  const int rc = use.step();
  if (rc == SQLITE_DONE) return {};
  const StoreStatus refused = fail(rc, "put keyframe " + to_string(r.key));
  if (rc != SQLITE_CONSTRAINT_PRIMARYKEY) return refused;
  if (stored_before) *stored_before = true;  // with its map cloud: both went in one savepoint
  return same_keyframe_stored(r, refused);
}

StoreStatus SqliteMapStore::same_keyframe_stored(const KeyframeRecord& r, const StoreStatus& refused) {
  Use use(stmt(kStoredKeyframe));
  use.i64(r.key.session).i64(r.key.index);
  if (use.step() != SQLITE_ROW) return refused;
  std::size_t n = 0;
  const std::uint8_t* pose = use.blob_at(1, n);
  const std::vector<std::uint8_t> mine = pose_blob(r.T_odom_sensor);
  const bool same = use.i64_at(0) == r.utime && static_cast<std::uint64_t>(use.i64_at(2)) == r.scan_fingerprint && n == mine.size() &&
                    std::memcmp(pose, mine.data(), n) == 0;
  if (same) return {};
  return {Code::kInvalid, "map " + path_ + ": put keyframe " + to_string(r.key) +
                              ": already stored with other content (another scan time, pose or scan fingerprint)"};
}

StoreStatus SqliteMapStore::read_keyframe(const Use& row, KeyframeLoad load, MapKeyframe& out) const {
  KeyframeRecord& r = out.record;
  r.key = KeyframeKey{static_cast<SessionId>(row.i64_at(0)), row.i64_at(1)};
  r.utime = row.i64_at(2);
  std::size_t n0 = 0, n1 = 0;
  const std::uint8_t* odom = row.blob_at(3, n0);
  const std::uint8_t* map = row.blob_at(4, n1);
  if (n0 != kPoseBytes || n1 != kPoseBytes)
    return corrupt("keyframe " + to_string(r.key) + ": a pose is not " + std::to_string(kPoseBytes) + " bytes");
  r.T_odom_sensor = read_pose(odom);
  out.T_map_sensor = read_pose(map);
  r.residual = row.f64_at(5);
  r.travelled = row.f64_at(6);
  r.scan_fingerprint = static_cast<std::uint64_t>(row.i64_at(16));
  std::size_t step_bytes = 0;
  const std::uint8_t* step = row.blob_at(17, step_bytes);
  if (step && step_bytes != blobs::kStepBytes)
    return corrupt("keyframe " + to_string(r.key) + ": its measured step is not " + std::to_string(blobs::kStepBytes) + " bytes");
  if (step) r.step = blobs::read_step(step);
  out.retired = row.i64_at(18) != 0;
  if (load == KeyframeLoad::kPose || row.i64_at(7) == 0) return {};
  auto f = std::make_shared<KeyframeFeatures>();
  if (load == KeyframeLoad::kFull) {
    std::size_t n = 0;
    const std::uint8_t* blob = row.blob_at(19, n);
    DecodedFeatures decoded = decode_features(blob, n);
    if (!decoded.ok) return corrupt("keyframe " + to_string(r.key) + ": " + decoded.error);
    *f = std::move(decoded.features);
  } else {
    f->ok = row.i64_at(8) != 0;
    f->error = row.text_at(9);
    f->input_points = static_cast<std::size_t>(row.i64_at(10));
    f->invalid_points = static_cast<std::size_t>(row.i64_at(11));
    f->ms_descriptor = row.f64_at(12);
    f->ms_prepare = row.f64_at(13);
  }
  std::size_t n = 0;
  const std::uint8_t* desc = row.blob_at(14, n);
  DecodedDescriptor descriptor = decode_descriptor(desc, n);
  if (!descriptor.ok) return corrupt("keyframe " + to_string(r.key) + ": " + descriptor.error);
  f->descriptor = std::move(descriptor.descriptor);
  const std::uint8_t* place = row.blob_at(15, n);
  if (place && n > 0) {  // NULL: written before the place descriptor existed (schema 1) or not computed
    DecodedPlaceDescriptor decoded = decode_place_descriptor(place, n);
    if (!decoded.ok) return corrupt("keyframe " + to_string(r.key) + ": " + decoded.error);
    f->place = std::move(decoded.descriptor);
  }
  r.features = std::move(f);
  return {};
}

StoreStatus SqliteMapStore::for_each_keyframe(std::optional<SessionId> session, KeyframeLoad load, const std::function<void(MapKeyframe&&)>& visit) {
  Use use(stmt(load == KeyframeLoad::kFull ? kKeyframesFull : kKeyframes));
  if (session) {
    use.i64(*session);
  } else {
    use.null();
  }
  int rc;
  while ((rc = use.step()) == SQLITE_ROW) {
    MapKeyframe keyframe;
    if (auto st = read_keyframe(use, load, keyframe); !st.ok()) return st;
    visit(std::move(keyframe));
  }
  return rc == SQLITE_DONE ? StoreStatus{} : fail(rc, "read keyframes");
}

StoreResult<PreparedScan> SqliteMapStore::get_prepared(const KeyframeKey& key) {
  StoreResult<PreparedScan> out;
  Use use(stmt(kPrepared));
  use.i64(key.session).i64(key.index);
  const int rc = use.step();
  if (rc == SQLITE_DONE) {
    out.status = {Code::kNotFound, "map " + path_ + ": no keyframe " + to_string(key)};
  } else if (rc != SQLITE_ROW) {
    out.status = fail(rc, "read keyframe " + to_string(key));
  } else if (use.i64_at(0) == 0) {
    out.status = {Code::kNotFound, "map " + path_ + ": keyframe " + to_string(key) + " has no features"};
  } else {
    std::size_t n = 0;
    const std::uint8_t* blob = use.blob_at(1, n);
    DecodedFeatures decoded = decode_features(blob, n);
    if (!decoded.ok) {
      out.status = corrupt("keyframe " + to_string(key) + ": " + decoded.error);
    } else {
      out.value = std::move(decoded.features.prepared);
    }
  }
  return out;
}

StoreResult<PointCloud> SqliteMapStore::get_map_cloud(const KeyframeKey& key) {
  StoreResult<PointCloud> out;
  Use use(stmt(kMapCloud));
  use.i64(key.session).i64(key.index);
  const int rc = use.step();
  if (rc == SQLITE_DONE) {
    out.status = {Code::kNotFound, "map " + path_ + ": keyframe " + to_string(key) + " has no map cloud"};
  } else if (rc != SQLITE_ROW) {
    out.status = fail(rc, "read the map cloud of keyframe " + to_string(key));
  } else {
    std::size_t n = 0;
    const std::uint8_t* blob = use.blob_at(0, n);
    DecodedMapCloud decoded = decode_map_cloud(blob, n);
    if (!decoded.ok)
      out.status = corrupt("keyframe " + to_string(key) + ": " + decoded.error);
    else
      out.value = std::move(decoded.cloud);
  }
  return out;
}

StoreStatus SqliteMapStore::retire_keyframes(const std::vector<KeyframeKey>& keys) {
  // All or nothing (a savepoint nests in the caller's transaction when there is one).
  if (auto st = exec("SAVEPOINT retire_keyframes", "retire keyframes"); !st.ok()) return st;
  StoreStatus st;
  for (const KeyframeKey& key : keys) {
    Use retire(stmt(kRetireKeyframe));
    retire.i64(key.session).i64(key.index);
    st = done(retire, "retire keyframe " + to_string(key));
    if (st.ok() && sqlite3_changes(db_) == 0) st = {Code::kNotFound, "map " + path_ + ": no keyframe " + to_string(key) + " to retire"};
    if (!st.ok()) break;
    Use cloud(stmt(kDeleteMapCloud));
    cloud.i64(key.session).i64(key.index);
    st = done(cloud, "delete the map cloud of keyframe " + to_string(key));
    if (!st.ok()) break;
  }
  if (!st.ok()) {
    exec("ROLLBACK TO retire_keyframes", "retire keyframes");
    exec("RELEASE retire_keyframes", "retire keyframes");
    return st;
  }
  return exec("RELEASE retire_keyframes", "retire keyframes");
}

StoreStatus SqliteMapStore::mark_decided(const KeyframeKey& key) {
  Use use(stmt(kMarkDecided));
  use.i64(key.session).i64(key.index);
  if (auto st = done(use, "mark keyframe " + to_string(key) + " decided"); !st.ok()) return st;
  if (sqlite3_changes(db_) == 0) return {Code::kNotFound, "map " + path_ + ": no keyframe " + to_string(key) + " to mark decided"};
  return {};
}

StoreResult<std::int64_t> SqliteMapStore::drop_undecided() {
  StoreResult<std::int64_t> out;
  // The decisions the undecided keyframes made, a correction one of those decisions made, then the keyframes: all or
  // nothing (a savepoint nests in the caller's transaction when there is one).
  const char* const steps[] = {
      ("DELETE FROM correction WHERE loop_event_id IN (SELECT event_id FROM loops JOIN keyframes ON session = query_session AND "
       "idx = query_idx WHERE decided = 0)"),
      "DELETE FROM loops WHERE EXISTS (SELECT 1 FROM keyframes WHERE session = query_session AND idx = query_idx AND decided = 0)",
      "DELETE FROM keyframes WHERE decided = 0",
  };
  if (out.status = exec("SAVEPOINT drop_undecided", "drop undecided keyframes"); !out.ok()) return out;
  for (const char* sql : steps) {
    out.status = exec(sql, "drop undecided keyframes");
    if (!out.ok()) {
      exec("ROLLBACK TO drop_undecided; RELEASE drop_undecided", "drop undecided keyframes");
      return out;
    }
    out.value = sqlite3_changes(db_);  // the last step's: keyframes removed
  }
  out.status = exec("RELEASE drop_undecided", "drop undecided keyframes");
  return out;
}

// ---- loops ----

StoreStatus SqliteMapStore::put_loop(const LoopDecision& l) {
  Use use(stmt(kPutLoop));
  use.i64(l.event_id).i64(l.query.session).i64(l.query.index).i64(l.match.session).i64(l.match.index).i64(l.query_utime).i64(l.match_utime);
  use.i64(status_code(l.status)).text(l.stage).text(l.reason);
  use.f64(l.gate_distance).f64(l.gate_radius).f64(l.descriptor_distance).f64(l.lcp_fraction).f64(l.icp_residual).f64(l.icp_fitness);
  use.f64(l.hungarian_consistency).f64(l.degeneracy);
  std::vector<std::uint8_t> information;
  append_doubles(information, l.information.data(), 36);
  use.blob(pose_blob(l.T_match_query)).blob(information).text(l.retrieval).f64(l.place_distance).i64(l.confirmed ? 1 : 0);
  const int rc = use.step();
  if (rc == SQLITE_DONE) return {};
  const StoreStatus refused = fail(rc, "put loop event " + std::to_string(l.event_id));
  return rc == SQLITE_CONSTRAINT_PRIMARYKEY ? same_loop_stored(l, refused) : refused;
}

StoreStatus SqliteMapStore::mark_published(std::int64_t event_id) {
  Use use(stmt(kMarkPublished));
  use.i64(event_id);
  return done(use, "mark loop event " + std::to_string(event_id) + " published");
}

StoreStatus SqliteMapStore::same_loop_stored(const LoopDecision& l, const StoreStatus& refused) {
  Use use(stmt(kStoredLoop));
  use.i64(l.event_id);
  if (use.step() != SQLITE_ROW) return refused;
  std::size_t n = 0;
  const std::uint8_t* pose = use.blob_at(5, n);
  const std::vector<std::uint8_t> mine = pose_blob(l.T_match_query);
  const bool same = use.i64_at(0) == l.query.session && use.i64_at(1) == l.query.index && use.i64_at(2) == l.match.session &&
                    use.i64_at(3) == l.match.index && use.i64_at(4) == status_code(l.status) && n == mine.size() &&
                    std::memcmp(pose, mine.data(), n) == 0;
  if (same) return {};
  return {Code::kInvalid, "map " + path_ + ": put loop event " + std::to_string(l.event_id) +
                              ": already stored with other content (other keyframes, status or transform)"};
}

StoreStatus SqliteMapStore::read_loop(const Use& row, LoopDecision& l) const {
  l.event_id = row.i64_at(0);
  l.query = KeyframeKey{static_cast<SessionId>(row.i64_at(1)), row.i64_at(2)};
  l.match = KeyframeKey{static_cast<SessionId>(row.i64_at(3)), row.i64_at(4)};
  l.query_utime = row.i64_at(5);
  l.match_utime = row.i64_at(6);
  if (!loop_status_from_code(row.i64_at(7), &l.status)) return corrupt("loop event " + std::to_string(l.event_id) + ": unknown status");
  l.stage = row.text_at(8);
  l.reason = row.text_at(9);
  double* fields[] = {&l.gate_distance, &l.gate_radius, &l.descriptor_distance,   &l.lcp_fraction,
                      &l.icp_residual,  &l.icp_fitness, &l.hungarian_consistency, &l.degeneracy};
  for (int i = 0; i < 8; ++i) *fields[i] = row.f64_at(10 + i);
  std::size_t np = 0, ni = 0;
  const std::uint8_t* pose = row.blob_at(18, np);
  const std::uint8_t* info = row.blob_at(19, ni);
  if (np != kPoseBytes || ni != 36 * sizeof(double)) {
    return corrupt("loop event " + std::to_string(l.event_id) + ": T_match_query or information has the wrong size");
  }
  l.T_match_query = read_pose(pose);
  std::memcpy(l.information.data(), info, ni);
  l.retrieval = row.text_at(20);
  l.place_distance = row.f64_at(21);
  l.confirmed = row.i64_at(22) != 0;
  l.published = row.i64_at(23) != 0;
  return {};
}

StoreStatus SqliteMapStore::for_each_loop(bool accepted_only, const std::function<void(LoopDecision&&)>& visit) {
  Use use(stmt(kLoops));
  use.i64(accepted_only ? 1 : 0);
  int rc;
  while ((rc = use.step()) == SQLITE_ROW) {
    LoopDecision loop;
    if (auto st = read_loop(use, loop); !st.ok()) return st;
    visit(std::move(loop));
  }
  return rc == SQLITE_DONE ? StoreStatus{} : fail(rc, "read loops");
}

// ---- correction ----

StoreStatus SqliteMapStore::put_correction(const CorrectionRecord& c) {
  if (c.keys.size() != c.T_map_sensor.size()) {
    return {Code::kInvalid, "map " + path_ + ": correction revision " + std::to_string(c.revision) + " has " + std::to_string(c.keys.size()) +
                                " keys but " + std::to_string(c.T_map_sensor.size()) + " poses"};
  }
  std::vector<std::uint8_t> keys, poses;
  keys.reserve(c.keys.size() * kKeyBytes);
  poses.reserve(c.T_map_sensor.size() * kPoseBytes);
  for (const KeyframeKey& k : c.keys) append_key(keys, k);
  for (const Eigen::Isometry3d& T : c.T_map_sensor) append_pose(poses, T);
  Use use(stmt(kPutCorrection));
  use.i64(c.revision)
      .i64(c.loop_event_id)
      .text(c.method)
      .blob(pose_blob(c.T_map_odom))
      .blob(keys)
      .blob(poses)
      .blob(c.corrector_state)
      .i64(c.ledger_seq);
  return done(use, "put correction revision " + std::to_string(c.revision));
}

// ---- loop ledger ----

StoreResult<std::int64_t> SqliteMapStore::put_ledger_entry(const LoopLedgerEntry& e) {
  StoreResult<std::int64_t> out;
  const std::string what = std::string(e.revoked ? "revoke" : "restore") + " loop event " + std::to_string(e.event_id);
  {
    Use use(stmt(kLoopState));
    use.i64(e.event_id);
    const int rc = use.step();
    if (rc == SQLITE_DONE) {
      out.status = {Code::kInvalid, "map " + path_ + ": " + what + ": the map holds no such loop"};
      return out;
    }
    if (rc != SQLITE_ROW) {
      out.status = fail(rc, what);
      return out;
    }
    if (use.i64_at(0) != status_code(LoopStatus::kAccepted)) {
      out.status = {Code::kInvalid, "map " + path_ + ": " + what + ": the loop was not accepted (only accepted loops are revoked)"};
      return out;
    }
    const bool revoked = !use.is_null(1) && use.i64_at(1) != 0;
    if (revoked == e.revoked) {
      out.status = {Code::kInvalid, "map " + path_ + ": " + what + ": the loop is " + (revoked ? "revoked already" : "not revoked")};
      return out;
    }
  }
  Use use(stmt(kPutLedger));
  use.i64(e.event_id).i64(e.revoked ? 1 : 0).text(e.who).text(e.reason).i64(e.utime);
  out.status = done(use, what);
  if (out.ok()) out.value = sqlite3_last_insert_rowid(db_);
  return out;
}

StoreResult<std::vector<LoopLedgerEntry>> SqliteMapStore::loop_ledger(std::int64_t after_seq) {
  StoreResult<std::vector<LoopLedgerEntry>> out;
  Use use(stmt(kLedger));
  use.i64(after_seq);
  int rc = SQLITE_ROW;
  while ((rc = use.step()) == SQLITE_ROW) {
    LoopLedgerEntry e;
    e.seq = use.i64_at(0);
    e.event_id = use.i64_at(1);
    e.revoked = use.i64_at(2) != 0;
    e.who = use.text_at(3);
    e.reason = use.text_at(4);
    e.utime = use.i64_at(5);
    out.value.push_back(std::move(e));
  }
  if (rc != SQLITE_DONE) out.status = fail(rc, "read the loop ledger");
  return out;
}

StoreStatus SqliteMapStore::read_correction(const Use& row, CorrectionRecord& c) const {
  c.revision = row.i64_at(0);
  c.loop_event_id = row.i64_at(1);
  c.method = row.text_at(2);
  std::size_t nt = 0, nk = 0, np = 0, ns = 0;
  const std::uint8_t* T = row.blob_at(3, nt);
  const std::uint8_t* keys = row.blob_at(4, nk);
  const std::uint8_t* poses = row.blob_at(5, np);
  const std::uint8_t* state = row.blob_at(6, ns);
  if (nt != kPoseBytes || nk % kKeyBytes != 0 || np % kPoseBytes != 0 || nk / kKeyBytes != np / kPoseBytes) {
    return corrupt("correction revision " + std::to_string(c.revision) + ": T_map_odom, keys (" + std::to_string(nk) + " bytes) or poses (" +
                   std::to_string(np) + " bytes) have the wrong size");
  }
  c.T_map_odom = read_pose(T);
  const std::size_t count = nk / kKeyBytes;
  c.keys.reserve(count);
  c.T_map_sensor.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    c.keys.push_back(read_key(keys + i * kKeyBytes));
    c.T_map_sensor.push_back(read_pose(poses + i * kPoseBytes));
  }
  if (ns > 0) c.corrector_state.assign(state, state + ns);
  c.ledger_seq = row.i64_at(7);
  return {};
}

StoreResult<std::optional<CorrectionRecord>> SqliteMapStore::correction() {
  StoreResult<std::optional<CorrectionRecord>> out;
  Use use(stmt(kCorrection));
  const int rc = use.step();
  if (rc == SQLITE_DONE) return out;
  if (rc != SQLITE_ROW) {
    out.status = fail(rc, "read the correction");
    return out;
  }
  CorrectionRecord c;
  out.status = read_correction(use, c);
  if (out.ok()) out.value = std::move(c);
  return out;
}

// ---- stats and check ----

StoreResult<MapStats> SqliteMapStore::stats() {
  StoreResult<MapStats> out;
  const std::pair<const char*, std::int64_t*> counts[] = {
      {"SELECT count(*) FROM sessions", &out.value.sessions},
      {"SELECT count(*) FROM keyframes", &out.value.keyframes},
      {"SELECT count(*) FROM keyframes WHERE retired = 1", &out.value.keyframes_retired},
      {"SELECT count(*) FROM loops WHERE status = 1", &out.value.loops_accepted},
      {"SELECT count(*) FROM loops WHERE status <> 1", &out.value.loops_rejected},
      {("SELECT count(*) FROM loops l WHERE l.status = 1 AND (SELECT e.revoked FROM loop_ledger e WHERE e.event_id = l.event_id "
        "ORDER BY e.seq DESC LIMIT 1) = 1"),
       &out.value.loops_revoked},
      {"SELECT count(*) FROM map_clouds", &out.value.map_clouds},
      {"SELECT coalesce(sum(points), 0) FROM map_clouds", &out.value.map_cloud_points},
      {"SELECT coalesce(sum(length(cloud)), 0) FROM map_clouds", &out.value.map_cloud_bytes},
  };
  for (const auto& [sql, value] : counts) {
    const auto r = scalar(sql, "count records");
    if (!r.ok()) {
      out.status = r.status;
      return out;
    }
    *value = r.value;
  }
  const auto pages = scalar("PRAGMA page_count", "read page_count");
  const auto page_size = scalar("PRAGMA page_size", "read page_size");
  if (!pages.ok() || !page_size.ok()) {
    out.status = pages.ok() ? page_size.status : pages.status;
    return out;
  }
  out.value.bytes = pages.value * page_size.value;
  struct stat wal {};
  if (path_ != ":memory:" && ::stat((path_ + "-wal").c_str(), &wal) == 0) out.value.bytes += static_cast<std::int64_t>(wal.st_size);
  return out;
}

std::vector<std::string> SqliteMapStore::invariant_problems() {
  std::vector<std::string> problems;
  const char* const queries[] = {
      ("SELECT 'loop event ' || event_id || ' names keyframe ' || query_session || '/' || query_idx || ', which is not stored' FROM loops "
       "WHERE NOT EXISTS (SELECT 1 FROM keyframes WHERE session = query_session AND idx = query_idx) LIMIT 10"),
      ("SELECT 'loop event ' || event_id || ' names keyframe ' || match_session || '/' || match_idx || ', which is not stored' FROM loops "
       "WHERE NOT EXISTS (SELECT 1 FROM keyframes WHERE session = match_session AND idx = match_idx) LIMIT 10"),
      ("SELECT 'session ' || session || ': keyframe indices are not 0..' || (count(*) - 1) || ' (min ' || min(idx) || ', max ' || "
       "max(idx) || ')' FROM keyframes GROUP BY session HAVING min(idx) <> 0 OR max(idx) <> count(*) - 1 LIMIT 10"),
      ("SELECT 'keyframe ' || session || '/' || idx || ' names session ' || session || ', which is not stored' FROM keyframes "
       "WHERE NOT EXISTS (SELECT 1 FROM sessions WHERE id = session) LIMIT 10"),
      ("SELECT 'keyframe ' || k.session || '/' || k.idx || ' is retired but keeps its features or map cloud' FROM keyframes k "
       "WHERE k.retired = 1 AND (k.has_features <> 0 OR EXISTS (SELECT 1 FROM map_clouds c WHERE c.session = k.session AND "
       "c.idx = k.idx)) LIMIT 10"),
  };
  for (const char* sql : queries) {
    Statement st;
    if (const int rc = st.prepare(db_, sql); rc != SQLITE_OK) {
      problems.push_back(fail(rc, "check invariants").message);
      continue;
    }
    Use use(st);
    while (use.step() == SQLITE_ROW) problems.push_back(use.text_at(0));
  }
  const auto c = correction();
  if (!c.ok()) {
    problems.push_back(c.status.message);
  } else if (c.value) {
    for (const KeyframeKey& key : c.value->keys) {
      Use use(stmt(kHasKeyframe));
      use.i64(key.session).i64(key.index);
      if (use.step() != SQLITE_ROW)
        problems.push_back("correction revision " + std::to_string(c.value->revision) + " names keyframe " + to_string(key) +
                           ", which is not stored");
      if (problems.size() >= 30) break;
    }
  }
  return problems;
}

StoreStatus SqliteMapStore::check() {
  std::vector<std::string> problems;
  {
    Statement st;
    int rc = st.prepare(db_, "PRAGMA integrity_check(10)");
    if (rc != SQLITE_OK) return fail(rc, "integrity check");
    Use use(st);
    while ((rc = use.step()) == SQLITE_ROW) {
      const std::string row = use.text_at(0);
      if (row != "ok") problems.push_back("integrity check: " + row);
    }
    if (rc != SQLITE_DONE) return fail(rc, "integrity check");
  }
  if (problems.empty()) problems = invariant_problems();
  if (problems.empty()) return {};
  std::string message = "map " + path_ + " fails its check (" + std::to_string(problems.size()) + " problems):";
  for (std::size_t i = 0; i < problems.size() && i < 10; ++i) message += "\n  " + problems[i];
  return {Code::kCorrupt, message};
}

std::int64_t SqliteMapStore::size_bytes() const {
  if (path_ == ":memory:") return 0;
  std::int64_t bytes = 0;
  for (const std::string& file : {path_, path_ + "-wal"}) {
    struct stat st {};
    if (::stat(file.c_str(), &st) == 0) bytes += static_cast<std::int64_t>(st.st_size);
  }
  return bytes;
}

// ---- open ----

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

/// @brief A file shorter than its own header says (cut by a copy or a full disk) is refused before SQLite reads
/// into the missing pages; only checked when no write-ahead log holds newer pages. Empty when fine.
std::string truncation_problem(const std::string& path) {
  struct stat file {
  }, wal{};
  if (::stat(path.c_str(), &file) != 0 || file.st_size == 0) return {};
  if (::stat((path + "-wal").c_str(), &wal) == 0 && wal.st_size > 0) return {};
  if (file.st_size < 100) return "is " + std::to_string(file.st_size) + " bytes, shorter than an SQLite header (not a loopd map, or truncated)";
  unsigned char h[100];
  std::ifstream in(path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(h), sizeof h)) return {};
  if (std::memcmp(h, "SQLite format 3", 16) != 0) return {};  // SQLite itself refuses it (not a database)
  const std::uint32_t page_size = (h[16] << 8 | h[17]) == 1 ? 65536u : static_cast<std::uint32_t>(h[16] << 8 | h[17]);
  const std::uint32_t pages = be32(h + 28);
  const bool header_size_valid = pages > 0 && be32(h + 24) == be32(h + 92);
  const auto expected = static_cast<std::int64_t>(pages) * page_size;
  if (header_size_valid && static_cast<std::int64_t>(file.st_size) < expected) {
    return "is truncated: " + std::to_string(file.st_size) + " bytes, its header says " + std::to_string(pages) + " pages of " +
           std::to_string(page_size) + " (" + std::to_string(expected) + " bytes)";
  }
  return {};
}

}  // namespace

OpenedMapStore open_sqlite_map_store(const MapStoreConfig& config) { return open_sqlite_map_store(config, parse_store_uri(config.uri).location); }

OpenedMapStore open_sqlite_map_store(const MapStoreConfig& config, const std::string& path) {
  OpenedMapStore out;
  if (path != ":memory:") {
    if (const std::string problem = truncation_problem(path); !problem.empty()) {
      out.status = {Code::kCorrupt, "map " + path + " " + problem};
      return out;
    }
  }
  sqlite3* db = nullptr;
  const int flags = (config.read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) | SQLITE_OPEN_NOMUTEX;
  const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    out.status = {code_of(rc), "map " + path + ": cannot open: " + sqlite3_errstr(rc) + (db ? std::string(" (") + sqlite3_errmsg(db) + ")" : "")};
    sqlite3_close_v2(db);
    return out;
  }
  auto store = std::make_unique<SqliteMapStore>(db, config.uri, path);
  out.status = store->setup(config);
  if (out.status.ok()) out.store = std::move(store);
  return out;
}

namespace {
// The back end registers itself for "sqlite" URIs (and plain file names, store_uri.hpp).
const bool registered =
    register_map_store_backend({"sqlite", "SQLite file (one writer)", false,
                                [](const MapStoreConfig& c, const std::string& location) { return open_sqlite_map_store(c, location); }});
}  // namespace

}  // namespace loopd
