// The loop ledger reaches a running engine: an operator revokes an accepted loop through a second connection to the
// map (as `loopd-map FILE loops --revoke` does) while a simulated drive is replayed; the next keyframe solves the graph
// again without it (a revision of method "ledger"), every later correction leaves it out, and the map stores the
// entry each correction honours. A restart finds nothing newer; a restore entered while stopped is applied at start.
#include <catch2/catch.hpp>

#include "loopd/runtime/ledger_watch.hpp"
#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "loopd/sim/drive.hpp"
#include "support/block_revisit_drive.hpp"
#include "support/engine_replay.hpp"
#include "support/open_test_map.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

LoopLedgerEntry entry(std::int64_t event, bool revoked) {
  LoopLedgerEntry e;
  e.event_id = event;
  e.revoked = revoked;
  e.who = "test operator";
  e.reason = revoked ? "doubled wall" : "it was right";
  e.utime = 1765100000000000;
  return e;
}

/// After the map writer: revokes the `revoke_at`th accepted loop through the operator's connection as it passes, and
/// keeps what each correction was.
struct Operator : EngineSink {
  MapStore* store = nullptr;
  int revoke_at = 4, accepted = 0;
  std::int64_t revoked_event = -1;
  struct Seen {
    std::string method;
    std::int64_t ledger_seq = 0, loops = 0, revision = 0;
    int accepted_before = 0;  ///< accepted decisions passed on before it
  };
  std::vector<Seen> corrections;
  void on_decision(const LoopDecision& d) override {
    if (!d.accepted() || ++accepted != revoke_at) return;
    const StoreResult<std::int64_t> put = store->put_ledger_entry(entry(d.event_id, true));
    INFO(put.status.message);
    REQUIRE(put.ok());
    revoked_event = d.event_id;
  }
  void on_correction(const CorrectionOutput& c) override {
    corrections.push_back({c.method, c.ledger_seq, c.resume_state.num_loops, c.revision, accepted});
  }
};

}  // namespace

TEST_CASE("engine: a loop revoked in the map while the drive runs leaves the graph at the next keyframe and stays out") {
  const Drive drive = test::block_revisit_drive();
  test::TempDir dir;
  const std::string path = dir.file("map.db");
  auto store = test::open_test_map(path);
  auto operator_connection = test::open_test_map(path);
  REQUIRE(store->put_session(SessionRecord{}).ok());

  Operator op;
  op.store = operator_connection.get();
  std::int64_t accepted_total = 0;
  {
    MapWriter writer(*store, op, 100);
    LoopdEngine engine(test::replay_config(), &writer);
    const ResumeSummary fresh = engine.resume(*store, false);
    REQUIRE(fresh.ok);
    LedgerWatch watch(*store, fresh.ledger, 0.0);  // every keyframe looks (loopd: map.ledger_poll)
    engine.set_ledger_feed([&watch] { return watch.poll(); });
    test::replay_drive(engine, drive);
    accepted_total = engine.stats().loops_accepted;
    CHECK(engine.stats().loops_revoked == 1);
    CHECK(engine.stats().ledger_corrections == 1);
    REQUIRE(writer.flush(5.0));
    CHECK(writer.stats().failures == 0);
  }
  REQUIRE(op.revoked_event >= 0);
  REQUIRE(accepted_total > op.revoke_at + 2);  // loops came after the revocation too
  std::size_t ledger_at = op.corrections.size();
  for (std::size_t i = 0; i < op.corrections.size(); ++i)
    if (op.corrections[i].method == "ledger") ledger_at = std::min(ledger_at, i);
  REQUIRE(ledger_at < op.corrections.size());
  const Operator::Seen& solved = op.corrections[ledger_at];
  CHECK(solved.ledger_seq == 1);
  CHECK(solved.loops == solved.accepted_before - 1);  // every loop accepted so far but the revoked one
  for (std::size_t i = ledger_at; i < op.corrections.size(); ++i) {
    INFO("correction " << i << " (" << op.corrections[i].method << ")");
    CHECK(op.corrections[i].ledger_seq == 1);
    CHECK(op.corrections[i].loops <= op.corrections[i].accepted_before - 1);
  }
  for (std::size_t i = 0; i < ledger_at; ++i) CHECK(op.corrections[i].ledger_seq == 0);
  const auto stored = store->correction();
  REQUIRE(stored.ok());
  REQUIRE(stored.value);
  CHECK(stored.value->ledger_seq == 1);
  CHECK(store->stats().value.loops_revoked == 1);

  // A restart on the map: an engine that only resumes, its corrections kept by `later` (which revokes nothing).
  Operator later;
  later.store = operator_connection.get();
  later.revoke_at = 1000000;
  const auto restart = [&](MapWriter& writer) {
    LoopdEngine engine(test::replay_config(), &writer);
    const ResumeSummary resumed = engine.resume(*store, true);
    INFO(resumed.error);
    REQUIRE(resumed.ok);
    REQUIRE(writer.flush(5.0));
    return resumed;
  };
  SECTION("a restart finds the correction as new as the ledger: nothing is solved again, the loop stays out") {
    MapWriter writer(*store, later, 100);
    const ResumeSummary resumed = restart(writer);
    CHECK_FALSE(resumed.ledger_corrected);
    CHECK(resumed.loops_revoked == 1);
    CHECK(resumed.corrections.empty());
  }
  SECTION("a restore entered while loopd was stopped is applied at start: the loop is back in the graph") {
    REQUIRE(operator_connection->put_ledger_entry(entry(op.revoked_event, false)).ok());
    MapWriter writer(*store, later, 100);
    const ResumeSummary resumed = restart(writer);
    CHECK(resumed.ledger_corrected);
    CHECK(resumed.loops_revoked == 0);
    REQUIRE(later.corrections.size() == 1);
    CHECK(later.corrections[0].method == "ledger");
    CHECK(later.corrections[0].ledger_seq == 2);
    CHECK(later.corrections[0].loops == accepted_total);  // every accepted loop, the restored one too
    const auto now = store->correction();
    REQUIRE(now.ok());
    REQUIRE(now.value);
    CHECK(now.value->ledger_seq == 2);
    CHECK(store->stats().value.loops_revoked == 0);
  }
}
