#pragma once
/// @file The loop ledger: what operators said about a map's accepted loops after loopd accepted them. An entry revokes a
/// loop (it leaves every later correction) or restores a revoked one; entries are never changed or removed, so the
/// ledger is each loop's history (who, why, when).
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace loopd {

/// @brief One ledger entry.
struct LoopLedgerEntry {
  std::int64_t seq = 0;       ///< position in the ledger, from 1 (set by the store)
  std::int64_t event_id = 0;  ///< the accepted loop it is about
  bool revoked = true;        ///< true: the loop is revoked from here on; false: restored
  std::string who;            ///< who entered it (loopd-map: the login name, or --who)
  std::string reason;         ///< why (free text; may be empty)
  std::int64_t utime = 0;     ///< [us] wall clock when it was entered
};

/// @brief The loops `ledger` leaves revoked after its entries up to `up_to_seq` (each loop's last entry decides).
std::set<std::int64_t> revoked_loops(const std::vector<LoopLedgerEntry>& ledger, std::int64_t up_to_seq = INT64_MAX);
/// @brief The newest entry's seq (0: an empty ledger).
std::int64_t newest_seq(const std::vector<LoopLedgerEntry>& ledger);

}  // namespace loopd
