#pragma once
/// @file Commits what the engine makes to the map store before the next sink publishes it.
#include <cstdint>
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
  std::string last_error;            ///< the refused write that stopped the map's writes, and why
};

/// @brief An EngineSink in front of another: each keyframe, decision and correction is committed to `store` first
/// (so anything seen on the bus is on disk), then passed on. After a refused write the writer writes nothing more
/// until restart, so the map stays a consistent prefix that a restart resumes from; what follows is counted as
/// refused and logged (1st, (N+1)th, ...), and every result is still passed on: loopd keeps detecting in memory.
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
  mutable std::mutex stats_mutex_;
  MapWriterStats stats_;
};

}  // namespace loopd
