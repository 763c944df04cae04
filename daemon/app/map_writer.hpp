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

#include "loopd/map/map_store.hpp"
#include "loopd_engine.hpp"

namespace loopd {

/// @brief What the map writer did, for status_t and the log.
struct MapWriterStats {
  std::int64_t keyframes_written = 0, decisions_written = 0, corrections_written = 0;
  std::int64_t map_cloud_bytes = 0;  ///< encoded map clouds written with the keyframes
  std::int64_t failures = 0;         ///< writes the store refused (the data stays in memory, detection goes on)
  std::int64_t busy_retries = 0;     ///< writes tried again because another process held the map's lock
  std::int64_t buffered = 0;         ///< writes waiting in memory for the map server (kUnavailable)
  std::int64_t flushed = 0;          ///< buffered writes stored after the server came back
  std::string last_error;            ///< the refused write that stopped the map's writes, and why
};

/// @brief An EngineSink in front of another: each keyframe, decision and correction is committed to `store` first
/// (so anything seen on the bus is on disk), then passed on. After a refused write the writer writes nothing more
/// until restart, so the map stays a consistent prefix that a restart resumes from; what follows is counted as
/// refused and logged (1st, (N+1)th, ...), and every result is still passed on: loopd keeps detecting in memory.
/// A write the store answers kUnavailable (a map server restarting or out of reach) is kept in memory, in order, with
/// every later write behind it; each later write first tries the buffer again, so the map catches up once the server
/// is back, and flush() at exit waits for it. Past max_buffered_keyframes buffered keyframes it counts as refused.
/// A write the store answers kBusy (another process, e.g. a backup, held the lock past busy_timeout_ms) is tried again
/// after 0.1, 0.4 and 1.6 s before it counts as refused.
class MapWriter : public EngineSink {
 public:
  /// @param correction_delay_ms fault injection for the crash test (LOOPD_FAULT_CORRECTION_DELAY_MS): widens the window
  ///        between an accepted loop's commit and its correction's, as a long pose-graph solve does.
  MapWriter(MapStore& store, EngineSink& next, int log_every_n, int correction_delay_ms = 0)
      : store_(store), next_(next), log_every_n_(log_every_n), correction_delay_ms_(correction_delay_ms) {}

  void on_keyframe(const KeyframeRecord& keyframe, const Eigen::Isometry3d& T_map_sensor, const MapCloudBlob& map_cloud) override;
  void on_decision(const LoopDecision& decision) override;
  void on_correction(const CorrectionOutput& correction) override;
  void on_keyframe_decided(const KeyframeKey& keyframe) override;
  MapWriterStats stats() const;
  /// @brief Writes what is buffered, trying for up to `timeout_s` while the server is unavailable; true when nothing
  /// is left (at exit: what is still buffered then is lost and counted in the log).
  bool flush(double timeout_s);
  void set_max_buffered_keyframes(std::int64_t n) { max_buffered_keyframes_ = n; }
  /// @brief What a session this run opens is recorded with (lidar preset, "replay drive.lcmlog" / "live udpm://...").
  void set_session_origin(std::string sensor, std::string source) {
    sensor_ = std::move(sensor);
    source_ = std::move(source);
  }

 private:
  /// @brief The session row of a keyframe's session exists (written with its first keyframe's time when new).
  StoreStatus ensure_session(SessionId session, std::int64_t first_utime);
  /// @brief The sessions' alignment and anchoring of a correction, written into their rows (inside its transaction).
  StoreStatus put_alignments(const std::vector<SessionAlignment>& alignments);
  void failed(const std::string& what, const StoreStatus& status);
  /// @brief Runs `transaction` (one whole write), or buffers it behind earlier ones while the server is unavailable.
  void write(std::string what, std::function<StoreStatus()> transaction, bool keyframe = false);
  void unavailable(const StoreStatus& status);
  bool flush_pending(bool wait);
  static StoreStatus stopped_status();
  /// @brief `write()`, tried again after a pause while the store answers kBusy; the last status.
  template <typename Write>
  StoreStatus retry_busy(Write&& write);

  MapStore& store_;
  EngineSink& next_;
  int log_every_n_;
  int correction_delay_ms_;
  bool decided_with_correction_ = false;  ///< the correction's transaction already marked the keyframe decided
  bool stopped_ = false;                  ///< a write was refused: nothing more is written
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
  std::chrono::steady_clock::time_point flush_deadline_{};
  mutable std::mutex stats_mutex_;
  MapWriterStats stats_;
};

}  // namespace loopd
