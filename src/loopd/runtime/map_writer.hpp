#pragma once
/// @file Commits what the engine makes to the map store before the next sink publishes it.
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "loopd/store/map_store.hpp"
#include "loopd/runtime/loopd_engine.hpp"

namespace loopd {

/// @brief What the map writer did, for status_t and the log.
struct MapWriterStats {
  std::int64_t keyframes_written = 0, decisions_written = 0, corrections_written = 0;
  std::int64_t map_cloud_bytes = 0;    ///< encoded map clouds written with the keyframes
  std::int64_t keyframes_retired = 0;  ///< keyframes retired in the map (place density policy)
  /// writes given up: refused for good (disk full, a record stored with other content), or past the buffer's bound;
  /// what they carried stays in memory (detection goes on) and is not in the map
  std::int64_t failures = 0;
  std::int64_t busy_retries = 0;  ///< tries again at once because another process held the map's lock
  std::int64_t retries = 0;       ///< tries again of buffered writes (the map busy or its server away), from the buffer
  std::int64_t buffered = 0;      ///< writes waiting in memory for the map (busy or unavailable), in order
  std::int64_t flushed = 0;       ///< buffered writes stored later
  std::string last_error;         ///< the first write given up and why, then what was lost with it
};

/// @brief An EngineSink in front of another: each keyframe, decision and correction is committed to `store` first
/// (so anything seen on the bus is on disk), then passed on; every result is passed on whatever the store says, so
/// loopd keeps detecting.
/// - Transient failures never stop it: a write the store answers kBusy (another process holds the lock past
///   busy_timeout_ms; tried again after 0.1 and 0.4 s first) or kUnavailable (a map server restarting or out of
///   reach) is kept in memory, in order, with every later write behind it, and the buffer is tried again with a
///   backoff of 0.25 s doubling to retry_period, at each later write and, while the engine is idle, from on_idle(): an
///   idle vehicle's buffer reaches the map within retry_period of its coming back. flush() at exit waits for it.
/// - A record already stored with the same content (a commit whose acknowledgement a lost connection took, retried)
///   is success: the stores' put_* are idempotent.
/// - A write refused for good (disk full, a record stored with other content), or a buffer past
///   max_buffered_keyframes keyframes, is given up loudly: the log and status name it and what was lost with it, and
///   the writer writes nothing more until restart, so the map stays a consistent prefix that a restart resumes from.
class MapWriter : public EngineSink {
 public:
  /// @param correction_delay_ms fault injection for the crash test (LOOPD_FAULT_CORRECTION_DELAY_MS): widens the window
  ///        between an accepted loop's commit and its correction's, as a long pose-graph solve does.
  MapWriter(MapStore& store, EngineSink& next, int log_every_n, int correction_delay_ms = 0)
      : store_(store), next_(next), log_every_n_(log_every_n), correction_delay_ms_(correction_delay_ms) {}

  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) override;
  void on_decision(const LoopDecision& decision) override;
  void on_correction(const CorrectionOutput& correction) override;
  /// @brief Stored as the map's correction too (the whole graph solved at the end of a run), then passed on.
  void on_final_correction(const CorrectionOutput& correction) override;
  void on_keyframe_decided(const KeyframeKey& keyframe) override;
  void on_keyframes_retired(const KeyframeKey& by, const std::vector<KeyframeKey>& retired) override;
  MapWriterStats stats() const;
  /// @brief Writes what is buffered, trying for up to `timeout_s` while the server is unavailable; true when nothing
  /// is left (at exit: what is still buffered then is lost and counted in the log).
  bool flush(double timeout_s);
  void set_max_buffered_keyframes(std::int64_t n) { max_buffered_keyframes_ = n; }
  /// @brief [s] the longest pause between tries of a buffered write (the backoff's cap).
  void set_retry_period(double seconds) { retry_period_ = std::chrono::milliseconds(static_cast<std::int64_t>(seconds * 1000.0)); }
  /// @brief Tries the buffer again when its backoff has passed (the engine's idle hook, never beside the others).
  void on_idle() override;
  /// @brief What a session this run opens is recorded with (lidar preset, "replay drive.lcmlog" / "live udpm://...").
  void set_session_origin(std::string sensor, std::string source) {
    sensor_ = std::move(sensor);
    source_ = std::move(source);
  }

 private:
  /// @brief The correction and "its newest keyframe is decided" in one transaction.
  void store_correction(const CorrectionOutput& correction);
  /// @brief The session row of a keyframe's session exists (written with its first keyframe's time when new).
  StoreStatus ensure_session(SessionId session, std::int64_t first_utime);
  /// @brief The sessions' alignment and anchoring of a correction, written into their rows (inside its transaction).
  StoreStatus put_alignments(const std::vector<SessionAlignment>& alignments);
  /// @brief Gives `what` up (and with it every buffered write: they depend on it), loudly; stops writing.
  void give_up(const std::string& what, const StoreStatus& status);
  /// @brief A write after giving up: counted, logged 1st, (N+1)th, ...
  void failed(const std::string& what, const StoreStatus& status);
  /// @brief Runs `transaction` (one whole write), or buffers it behind earlier ones while the server is unavailable.
  void write(std::string what, std::function<StoreStatus()> transaction, bool keyframe = false);
  void waiting(const StoreStatus& status);
  /// @brief The buffer's next try is due (or `wait`: at exit).
  bool retry_due() const { return std::chrono::steady_clock::now() >= next_retry_; }
  bool flush_pending(bool wait);
  static StoreStatus stopped_status();
  /// @brief `write()`, tried again after a pause while the store answers kBusy; the last status.
  template <typename Write>
  StoreStatus retry_busy(Write&& write);

  MapStore& store_;
  EngineSink& next_;
  int log_every_n_;
  int correction_delay_ms_;
  /// The newest correction's transaction marked this keyframe decided (its newest); a correction made between keyframes
  /// (at resume, or by the loop ledger) names one decided before, and the next keyframe is still marked.
  std::optional<KeyframeKey> decided_with_correction_;
  bool stopped_ = false;  ///< a write was refused: nothing more is written
  std::string sensor_, source_;
  std::optional<std::map<SessionId, SessionRecord>> sessions_;  ///< the store's session rows (read at the first keyframe)
  struct Pending {
    std::string what;
    std::function<StoreStatus()> transaction;
    bool keyframe = false;
  };
  std::deque<Pending> pending_;  ///< writes waiting for the server, in order
  std::int64_t buffered_keyframes_ = 0, max_buffered_keyframes_ = 5000;
  bool buffering_ = false;
  std::chrono::steady_clock::time_point flush_deadline_{}, next_retry_{};
  std::chrono::milliseconds backoff_{250}, retry_period_{2000};
  mutable std::mutex stats_mutex_;
  MapWriterStats stats_;
};

}  // namespace loopd
