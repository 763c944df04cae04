#pragma once
/// @file The fleet side of a map store that several loopd processes (one per vehicle) write at once: the other
/// vehicles' keyframes as they are decided, who solves the joint pose graph, and the joint correction. No SQL here.
#include <cstdint>
#include <functional>
#include <map>
#include <optional>

#include "loopd/records/store_records.hpp"
#include "loopd/store/map_store.hpp"

namespace loopd {

/// @brief A store shared by a fleet (MapStore::shared()). The store's own vehicle (MapStoreConfig::vehicle) writes its
/// sessions through MapStore; this reads the rest. Same threading rule as MapStore (one thread at a time).
class SharedMap {
 public:
  virtual ~SharedMap() = default;

  /// @brief Decided keyframes of the other vehicles' sessions not seen yet, in key order: for each session those with
  /// an index above `newest_seen[session]` (absent: all); `newest_seen` is advanced past what was visited. A session's
  /// keyframes are decided in index order, so this never skips one.
  virtual StoreStatus for_each_new_remote_keyframe(std::map<SessionId, std::int64_t>& newest_seen, KeyframeLoad load,
                                                   const std::function<void(MapKeyframe&&)>& visit) = 0;

  /// @brief Takes (or keeps) the fleet's solver role: true while this connection holds it. It is a server-side lock
  /// on the connection, released when the process dies or the connection is lost, and then taken by the next asker.
  virtual StoreResult<bool> hold_solver_lock() = 0;

  /// @brief Every decided keyframe of every vehicle, pose-deep (KeyframeLoad::kPose), in key order.
  virtual StoreStatus for_each_fleet_keyframe(const std::function<void(MapKeyframe&&)>& visit) = 0;
  /// @brief Every accepted loop of every vehicle whose two keyframes are decided, but those the loop ledger revokes.
  virtual StoreStatus for_each_fleet_loop(const std::function<void(LoopDecision&&)>& visit) = 0;
  virtual StoreResult<FleetCounts> fleet_counts() = 0;

  /// @brief Stores a joint correction as the next revision (record.revision is ignored: the stored one is returned).
  virtual StoreResult<std::int64_t> put_fleet_correction(const FleetCorrectionRecord& record) = 0;
  /// @brief The newest joint correction (nullopt: none yet), or only when newer than `after_revision`.
  virtual StoreResult<std::optional<FleetCorrectionRecord>> fleet_correction(std::int64_t after_revision = 0) = 0;
};

}  // namespace loopd
