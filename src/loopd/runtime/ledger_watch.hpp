#pragma once
/// @file Watching a map's loop ledger while loopd runs: an operator's `loopd-map FILE loops --revoke EVENT` reaches the
/// running detector within a poll period.
#include <chrono>
#include <cstdint>
#include <optional>
#include <set>
#include <vector>

#include "loopd/store/map_store.hpp"

namespace loopd {

/// @brief What the ledger says now: the loops revoked by its entries up to ledger_seq.
struct LedgerState {
  std::set<std::int64_t> revoked;
  std::int64_t ledger_seq = 0;
};

/// @brief Reads the ledger's new entries at most once per period, from the thread that owns the store (the engine's
/// sequential stage). Not thread-safe.
class LedgerWatch {
 public:
  /// @param entries the ledger as resume read it (the watch starts after its newest entry)
  LedgerWatch(MapStore& store, std::vector<LoopLedgerEntry> entries, double period_s);
  /// @brief The ledger's state when entries arrived since the last call that returned one; nullopt when none did, the
  /// period has not passed, or the store could not be read (logged once, tried again next period).
  std::optional<LedgerState> poll();
  std::int64_t entries_seen() const { return static_cast<std::int64_t>(entries_.size()); }

 private:
  MapStore& store_;
  std::vector<LoopLedgerEntry> entries_;
  std::chrono::steady_clock::duration period_;
  std::chrono::steady_clock::time_point next_poll_{};
  bool read_failed_logged_ = false;
};

}  // namespace loopd
