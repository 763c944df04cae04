#pragma once
/// @file The map store: where keyframes, loop decisions and the correction state outlive the process. One interface,
/// back ends behind it (SQLite now, PostgreSQL later); no SQL and no back-end header in this file. The detector never
/// sees it: the engine writes to it and loads from it.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopd/base/point_cloud.hpp"
#include "loopd/records/loop_ledger.hpp"
#include "loopd/records/store_records.hpp"

namespace loopd {

/// @brief Outcome of a store operation: the engine must tell "retry later" from "the map is damaged".
struct StoreStatus {
  enum class Code {
    kOk,
    kNotFound,  ///< no such record
    kBusy,      ///< locked by another process: retry
    kCorrupt,   ///< damaged file or record, or a schema this build does not know
    kIo,        ///< the disk refused (full, read-only, gone)
    kInvalid,   ///< bad argument or configuration
    /// the database server cannot be reached (connection lost, server restarting): the write did not happen and may be
    /// tried again later (the store reconnects on the next call, at most once a second)
    kUnavailable,
  };
  Code code = Code::kOk;
  std::string message;  ///< what happened, naming the map and the record
  bool ok() const { return code == Code::kOk; }
};

/// @brief A value read from the store, or why it could not be.
template <typename T>
struct StoreResult {
  StoreStatus status;
  T value{};
  bool ok() const { return status.ok(); }
};

/// @brief Where the map lives and how hard it holds on to what it was told.
struct MapStoreConfig {
  /// "FILE" or "sqlite://FILE" (an SQLite file, created when missing), "sqlite::memory:" (tests), or
  /// "postgresql://[user[:password]@][host][:port]/database[?param=value...]" (a libpq connection URI, e.g.
  /// "postgresql://loopd:secret@/fleet?host=/run/postgresql"): a map shared by a fleet on a PostgreSQL server.
  std::string uri;
  /// SQLite `synchronous` in WAL mode: "normal" (a committed record survives a crash of loopd; the last commits may be
  /// lost on power loss) or "full" (survives power loss; an fsync per commit).
  std::string synchronous = "normal";
  bool read_only = false;      ///< open an existing map for reading only (loopd-map)
  int busy_timeout_ms = 5000;  ///< how long a write waits for another process's lock before kBusy [ms]
  /// Cap on the map's size in pages of 4 KiB (SQLite `max_page_count`; 0: no cap beyond SQLite's own). A write past it
  /// fails with kIo as on a full disk: tests simulate a full disk with it.
  std::int64_t max_pages = 0;
  /// The fleet vehicle this process writes for (a shared back end only; -1: none). Its sessions are numbered
  /// vehicle * kSessionsPerVehicle + k (records/vehicle_sessions.hpp), and the MapStore verbs (for_each_keyframe(nullopt), for_each_loop, correction,
  /// drop_undecided, stats, check) see only its own sessions and decisions; the other vehicles' are read through
  /// shared() (store/shared_map.hpp). -1 sees the whole map (loopd-map, the single-vehicle daemon).
  int vehicle = -1;
  std::optional<std::string> validate() const;
};

class SharedMap;

/// @brief Persistent keyframes, loop decisions and correction state of one map (all its sessions).
/// Not thread-safe: one thread (the engine's sequential stage, or a writer it owns) uses it at a time.
class MapStore {
 public:
  MapStore() = default;
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;
  virtual ~MapStore() = default;

  /// @brief The URI the store was opened with (for messages).
  virtual const std::string& uri() const = 0;
  /// @brief [bytes] the map's size where it lives (file and journal, or the server's database), as last seen; any
  /// thread may call it, and it never waits for the store (status_t reads it from the LCM thread).
  virtual std::int64_t size_bytes() const = 0;

  /// @brief Groups the writes until commit() into one transaction (all or nothing on a crash).
  virtual StoreStatus begin() = 0;
  virtual StoreStatus commit() = 0;
  virtual StoreStatus rollback() = 0;

  /// @brief Adds or replaces a session.
  virtual StoreStatus put_session(const SessionRecord& session) = 0;
  virtual StoreResult<std::vector<SessionRecord>> sessions() = 0;

  /// @brief Adds a keyframe (its key must be new): pose, travel, and the features when present.
  virtual StoreStatus put_keyframe(const MapKeyframe& keyframe) = 0;
  /// @brief Every keyframe of `session` (all sessions when nullopt) in key order, read as deep as `load` says.
  virtual StoreStatus for_each_keyframe(std::optional<SessionId> session, KeyframeLoad load, const std::function<void(MapKeyframe&&)>& visit) = 0;
  /// @brief The prepared scan of one keyframe (kNotFound when it has none).
  virtual StoreResult<PreparedScan> get_prepared(const KeyframeKey& key) = 0;

  /// @brief The map cloud of one keyframe, decoded (sensor frame); kNotFound when it has none.
  virtual StoreResult<PointCloud> get_map_cloud(const KeyframeKey& key) = 0;

  /// @brief Retires decided keyframes (the place density policy, area-bounded maps): each row keeps its key, time,
  /// poses, travel and step (its place in the odometry chain, its loops' ends) and is marked retired; its features and
  /// map cloud are deleted. Read back with features null, as a shed keyframe is. Keys already retired are left as they
  /// are; a key the map does not hold (of this vehicle's, with a vehicle set) is refused (kNotFound) and nothing is retired.
  virtual StoreStatus retire_keyframes(const std::vector<KeyframeKey>& keys) = 0;
  /// @brief Marks a keyframe decided: every decision it made (and its correction) is stored.
  virtual StoreStatus mark_decided(const KeyframeKey& key) = 0;
  /// @brief Removes the keyframes not marked decided and the decisions they made (a stop cut them off; they are
  /// processed again on resume). Returns how many keyframes were removed.
  virtual StoreResult<std::int64_t> drop_undecided() = 0;

  /// @brief Adds a loop decision, not yet published. Its event id is new, or stored with the same content (a write
  /// retried after its commit went through: success); stored with other content it is refused (kInvalid).
  virtual StoreStatus put_loop(const LoopDecision& loop) = 0;
  /// @brief The decision `event_id` reached the bus (a restart that makes it again does not publish it again).
  virtual StoreStatus mark_published(std::int64_t event_id) = 0;
  /// @brief Every decision in event order; accepted_only: only accepted loops.
  virtual StoreStatus for_each_loop(bool accepted_only, const std::function<void(LoopDecision&&)>& visit) = 0;

  /// @brief Appends `entry` to the loop ledger and returns its seq (entry.seq is ignored). Refused (kInvalid, saying
  /// why) unless entry.event_id is an accepted loop of this map (of this vehicle's, with a vehicle set) that the entry
  /// changes: revoking a revoked loop, or restoring one not revoked, is refused.
  virtual StoreResult<std::int64_t> put_ledger_entry(const LoopLedgerEntry& entry) = 0;
  /// @brief The ledger's entries with seq > after_seq, in order (after_seq: the newest one seen; a poll for news).
  virtual StoreResult<std::vector<LoopLedgerEntry>> loop_ledger(std::int64_t after_seq = 0) = 0;

  /// @brief Replaces the stored correction state.
  virtual StoreStatus put_correction(const CorrectionRecord& correction) = 0;
  /// @brief The newest correction state (value nullopt when the map has none yet).
  virtual StoreResult<std::optional<CorrectionRecord>> correction() = 0;

  virtual StoreResult<MapStats> stats() = 0;
  /// @brief The back end's own integrity check plus the map's invariants (every loop names stored keyframes, keys
  /// consecutive within a session, correction keys stored); kCorrupt with the first problems found.
  virtual StoreStatus check() = 0;

  /// @brief The map's fleet side (what other vehicles wrote, the joint correction), or null when the back end is not
  /// shared (SQLite: one writer).
  virtual SharedMap* shared() { return nullptr; }
};

/// @brief A store opened by open_map_store, or why it could not be opened.
struct OpenedMapStore {
  std::unique_ptr<MapStore> store;
  StoreStatus status;
};

/// @brief Opens (or creates) the map `config.uri` names, through the back end registered for its scheme
/// (store_uri.hpp). A map of an unknown schema version is refused (kCorrupt), an unknown scheme kInvalid.
OpenedMapStore open_map_store(const MapStoreConfig& config);

/// @brief A back end of the map store, as it registers itself (a registrar object in its own .cpp; its library is
/// linked whole, see src/CMakeLists.txt).
struct MapStoreBackend {
  std::string scheme;       ///< the URI scheme it opens (store_uri.hpp), e.g. "sqlite", "postgresql"
  std::string description;  ///< one line for messages ("SQLite file", "PostgreSQL server (a fleet map)")
  bool shared = false;      ///< several writers (vehicles) on one map: MapStore::shared() is not null
  OpenedMapStore (*open)(const MapStoreConfig& config, const std::string& location) = nullptr;
};
/// @brief Adds a back end (a later one with the same scheme replaces it). Returns true (for a static registrar).
bool register_map_store_backend(const MapStoreBackend& backend);
/// @brief The back end registered for `scheme`, or null.
const MapStoreBackend* find_map_store_backend(const std::string& scheme);
/// @brief The registered schemes, sorted ("postgresql, sqlite"), for messages.
std::string map_store_schemes();

/// @brief "kOk", "kNotFound", "kBusy", "kCorrupt", "kIo", "kInvalid", "kUnavailable" (messages, tests).
const char* to_string(StoreStatus::Code code);

}  // namespace loopd
