#include "loopd/records/loop_ledger.hpp"

#include <algorithm>

namespace loopd {

std::set<std::int64_t> revoked_loops(const std::vector<LoopLedgerEntry>& ledger, std::int64_t up_to_seq) {
  std::set<std::int64_t> revoked;
  for (const LoopLedgerEntry& e : ledger) {
    if (e.seq > up_to_seq) continue;
    if (e.revoked)
      revoked.insert(e.event_id);
    else
      revoked.erase(e.event_id);
  }
  return revoked;
}

std::int64_t newest_seq(const std::vector<LoopLedgerEntry>& ledger) {
  std::int64_t seq = 0;
  for (const LoopLedgerEntry& e : ledger) seq = std::max(seq, e.seq);
  return seq;
}

}  // namespace loopd
