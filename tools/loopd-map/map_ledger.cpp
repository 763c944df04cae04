// loopd-map loops --revoke / --restore and loopd-map ledger: the loop ledger of a map. An entry takes an accepted loop
// out of every later correction (or puts it back); it is never changed or removed, so the ledger says who did what,
// when and why. The correction itself is made again by `correct`, by a running loopd within map.ledger_poll, or by
// loopd at its next start.
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <pwd.h>
#include <unistd.h>

#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief The login name of this process's user ("uid N" when it has none).
std::string login_name() {
  if (const passwd* pw = ::getpwuid(::geteuid()); pw && pw->pw_name) return pw->pw_name;
  return "uid " + std::to_string(::geteuid());
}

std::int64_t now_utime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// @brief "2026-12-07 18:04:05" (UTC) of a wall-clock time in microseconds.
std::string utc_time(std::int64_t utime) {
  const std::time_t t = static_cast<std::time_t>(utime / 1000000);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S", &tm);
  return text;
}

nlohmann::json entry_json(const LoopLedgerEntry& e) {
  return {{"seq", e.seq}, {"event_id", e.event_id}, {"action", e.revoked ? "revoke" : "restore"},
          {"who", e.who}, {"reason", e.reason},     {"utime", e.utime}};
}

}  // namespace

int run_ledger_entry(MapStore& store, const LedgerEntryOptions& entry, const CommandOptions& options) {
  LoopLedgerEntry e;
  e.event_id = entry.event_id;
  e.revoked = entry.revoke;
  e.who = entry.who.empty() ? login_name() : entry.who;
  e.reason = entry.reason;
  e.utime = now_utime();
  const StoreResult<std::int64_t> put = store.put_ledger_entry(e);
  if (!put.ok()) {
    std::cerr << "loopd-map: " << put.status.message << "\n";
    return kExitBadInput;
  }
  e.seq = put.value;
  std::cout << "loop event " << e.event_id << (e.revoked ? " revoked" : " restored") << " by " << e.who << " (ledger entry " << e.seq << ")"
            << (e.reason.empty() ? "" : ": " + e.reason) << "\n"
            << "the map's correction is made again by `loopd-map " << store.uri() << " correct` (loopd stopped), by a running loopd "
            << "within map.ledger_poll, or by loopd at its next start\n";
  if (options.json) print_json_line(entry_json(e));
  return kExitOk;
}

int run_ledger(MapStore& store, const CommandOptions& options) {
  const StoreResult<std::vector<LoopLedgerEntry>> ledger = store.loop_ledger();
  const StoreResult<std::optional<CorrectionRecord>> correction = store.correction();
  for (const StoreStatus* s : {&ledger.status, &correction.status})
    if (!s->ok()) {
      std::cerr << "loopd-map: " << s->message << "\n";
      return kExitBadInput;
    }
  Table table({"entry", "event", "action", "who", "utc", "reason"});
  nlohmann::json list = nlohmann::json::array();
  for (const LoopLedgerEntry& e : ledger.value) {
    table.add({std::to_string(e.seq), std::to_string(e.event_id), e.revoked ? "revoke" : "restore", e.who, utc_time(e.utime), e.reason});
    list.push_back(entry_json(e));
  }
  const std::set<std::int64_t> revoked = revoked_loops(ledger.value);
  const std::int64_t honoured = correction.value ? correction.value->ledger_seq : 0;
  std::cout << table.str() << ledger.value.size() << " entries, " << revoked.size()
            << " loops revoked now; the stored correction honours entries up to " << honoured
            << (honoured < newest_seq(ledger.value) ? " (older than the ledger: run correct)" : "") << "\n";
  if (options.json)
    print_json_line({{"entries", list},
                     {"revoked", std::vector<std::int64_t>(revoked.begin(), revoked.end())},
                     {"ledger_seq", newest_seq(ledger.value)},
                     {"correction_ledger_seq", honoured}});
  return kExitOk;
}

}  // namespace loopd::tools
