#include "loopd/runtime/ledger_watch.hpp"

#include <cstdio>

#include "loopd/runtime/log_level.hpp"

namespace loopd {

LedgerWatch::LedgerWatch(MapStore& store, std::vector<LoopLedgerEntry> entries, double period_s)
    : store_(store),
      entries_(std::move(entries)),
      period_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(period_s))) {}

std::optional<LedgerState> LedgerWatch::poll() {
  const auto now = std::chrono::steady_clock::now();
  if (now < next_poll_) return std::nullopt;
  next_poll_ = now + period_;
  StoreResult<std::vector<LoopLedgerEntry>> news = store_.loop_ledger(newest_seq(entries_));
  if (!news.ok()) {
    if (!read_failed_logged_)
      std::fprintf(stderr, "loopd: cannot read the loop ledger (tried again every period): %s\n", news.status.message.c_str());
    read_failed_logged_ = true;
    return std::nullopt;
  }
  if (news.value.empty()) return std::nullopt;
  for (LoopLedgerEntry& e : news.value) {
    if (log_enabled(LogLevel::kInfo))
      std::fprintf(stderr, "loopd: loop ledger entry %lld: loop event %lld %s by %s%s%s\n", static_cast<long long>(e.seq),
                   static_cast<long long>(e.event_id), e.revoked ? "revoked" : "restored", e.who.c_str(), e.reason.empty() ? "" : ": ",
                   e.reason.c_str());
    entries_.push_back(std::move(e));
  }
  return LedgerState{revoked_loops(entries_), newest_seq(entries_)};
}

}  // namespace loopd
