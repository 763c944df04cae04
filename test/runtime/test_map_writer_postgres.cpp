// MapWriter on a real PostgreSQL server of the test's own (scripts/pg-local): a commit that reached the server while
// its acknowledgement was lost with the connection is retried, meets its own key, and is success (not a second row,
// not a writer that stops); a server that goes away while the vehicle is idle gets the buffer within the retry period.
//
// The lost acknowledgement is made the way PostgreSQL documents it: with synchronous_standby_names naming a standby
// that never comes, COMMIT writes the transaction locally and waits; the backend terminated during that wait keeps
// the transaction ("has already committed locally") and never answers the client.
#include <catch2/catch.hpp>

#include <chrono>
#include <thread>

#include "loopd/store/map_store.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "support/postgres_server.hpp"

using namespace loopd;

namespace {

struct Counter : EngineSink {
  int decisions = 0;
  void on_decision(const LoopDecision&) override { ++decisions; }
  void on_correction(const CorrectionOutput&) override {}
};

KeyframeRecord keyframe(std::int64_t index) {
  KeyframeRecord k;
  k.key = KeyframeKey{0, index};
  k.utime = 1000000 * (index + 1);
  k.T_odom_sensor.translation() = Eigen::Vector3d(static_cast<double>(index), 0.5, 0);
  k.scan_fingerprint = 0x1234500ull + static_cast<std::uint64_t>(index);
  return k;
}

std::vector<MapKeyframe> stored(MapStore& store) {
  std::vector<MapKeyframe> all;
  REQUIRE(store.for_each_keyframe(std::nullopt, KeyframeLoad::kPose, [&](MapKeyframe&& k) { all.push_back(std::move(k)); }).ok());
  return all;
}

/// Calls on_idle() every 20 ms until `done` or `seconds` pass; true when done.
template <typename Done>
bool idle_until(MapWriter& writer, double seconds, Done done) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(seconds * 1000));
  while (std::chrono::steady_clock::now() < until) {
    writer.on_idle();
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

test::PostgresServer* own_server() {
  static test::PostgresServer server("loopdtest1");
  static const bool started = server.start();
  if (!started) {
    if (server.binaries_missing()) {
      WARN("PostgreSQL server binaries missing: skipped (" << server.reason() << ")");
      return nullptr;
    }
    FAIL("PostgreSQL test server did not start: " << server.reason());
  }
  return &server;
}

/// A fresh database `name` on the test's server, opened as a map store.
OpenedMapStore open_fresh_map(test::PostgresServer& server, const std::string& name) {
  MapStoreConfig config;
  config.uri = server.create_database(name);
  REQUIRE(!config.uri.empty());
  OpenedMapStore opened = open_map_store(config);
  REQUIRE(opened.status.ok());
  return opened;
}

}  // namespace

TEST_CASE("map writer on postgres: a commit whose acknowledgement is lost is stored once and the writer goes on", "[postgres]") {
  test::PostgresServer* server = own_server();
  if (!server) return;
  OpenedMapStore opened = open_fresh_map(*server, "lost_ack");
  const std::string uri = server->uri_with_password("loopdtest1", "lost_ack");
  MapStore& store = *opened.store;
  Counter next;
  MapWriter writer(store, next, 1000);
  writer.set_retry_period(0.5);
  writer.on_keyframe(keyframe(0), Eigen::Isometry3d::Identity(), nullptr);
  REQUIRE(writer.stats().keyframes_written == 1);

  // Every COMMIT now waits for a standby that never comes; a watcher terminates the backend that waits.
  REQUIRE(server->sql(uri, "ALTER SYSTEM SET synchronous_standby_names = 'never_there'"));
  REQUIRE(server->sql(uri, "SELECT pg_reload_conf()"));
  // The reload is asynchronous: the postmaster rereads the file, then signals the backends, which apply it between
  // commands. Wait until a new connection (forked after the postmaster's reload) sees the setting, so that the
  // writer's backend has been signalled before its next transaction; without this the commit below could go through
  // unaffected now and then (seen under ctest -j2).
  bool reloaded = false;
  for (int i = 0; i < 200 && !reloaded; ++i) {
    reloaded = server->sql(uri, "DO $$ BEGIN IF current_setting('synchronous_standby_names') <> 'never_there' THEN RAISE 'not yet'; END IF; END $$");
    if (!reloaded) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  REQUIRE(reloaded);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  bool terminated = false;
  std::thread watcher([&] {
    terminated = server->sql(uri,
                             "DO $$ BEGIN FOR i IN 1..400 LOOP EXIT WHEN EXISTS (SELECT 1 FROM pg_stat_activity WHERE wait_event = "
                             "'SyncRep'); PERFORM pg_sleep(0.025); END LOOP; IF NOT EXISTS (SELECT 1 FROM pg_stat_activity WHERE "
                             "wait_event = 'SyncRep') THEN RAISE 'no commit waited'; END IF; PERFORM pg_terminate_backend(pid) FROM "
                             "pg_stat_activity WHERE wait_event = 'SyncRep'; END $$");
  });
  writer.on_keyframe(keyframe(1), Eigen::Isometry3d::Identity(), nullptr);
  watcher.join();
  REQUIRE(terminated);
  MapWriterStats s = writer.stats();
  INFO(s.last_error);
  CHECK(s.failures == 0);
  CHECK(s.buffered == 1);  // the writer did not see the commit: it waits to try again
  CHECK(s.keyframes_written == 1);

  // The commit went through all the same: keyframe 1 is on the server already.
  REQUIRE(server->sql(uri, "ALTER SYSTEM RESET synchronous_standby_names"));
  REQUIRE(server->sql(uri, "SELECT pg_reload_conf()"));
  REQUIRE(server->sql(uri, "DO $$ BEGIN IF (SELECT count(*) FROM keyframes) <> 2 THEN RAISE 'not committed'; END IF; END $$"));

  // Tried again from the idle hook (no new keyframe comes): it meets its own key with the same content, and that is
  // success; the writer goes on writing.
  REQUIRE(idle_until(writer, 10.0, [&] { return writer.stats().buffered == 0; }));
  s = writer.stats();
  CHECK(s.failures == 0);
  CHECK(s.flushed == 1);
  CHECK(s.keyframes_written == 2);
  CHECK(s.last_error.empty());
  writer.on_keyframe(keyframe(2), Eigen::Isometry3d::Identity(), nullptr);
  CHECK(writer.stats().keyframes_written == 3);
  CHECK(writer.stats().failures == 0);
  const std::vector<MapKeyframe> all = stored(store);
  REQUIRE(all.size() == 3);
  for (std::int64_t i = 0; i < 3; ++i) {
    CHECK(all[static_cast<std::size_t>(i)].record.key.index == i);
    CHECK(all[static_cast<std::size_t>(i)].record.scan_fingerprint == keyframe(i).scan_fingerprint);
  }
}

TEST_CASE("map writer on postgres: an idle vehicle's buffer reaches the server within the retry period of its return", "[postgres]") {
  test::PostgresServer* server = own_server();
  if (!server) return;
  OpenedMapStore opened = open_fresh_map(*server, "idle_flush");
  Counter next;
  MapWriter writer(*opened.store, next, 1000);
  writer.set_retry_period(1.0);
  writer.on_keyframe(keyframe(0), Eigen::Isometry3d::Identity(), nullptr);
  REQUIRE(writer.stats().keyframes_written == 1);

  REQUIRE(server->stop("immediate"));
  for (std::int64_t i = 1; i <= 3; ++i) writer.on_keyframe(keyframe(i), Eigen::Isometry3d::Identity(), nullptr);
  LoopDecision d;
  d.event_id = 1;
  d.query = KeyframeKey{0, 3};
  d.match = KeyframeKey{0, 0};
  d.status = LoopStatus::kRejected;
  d.stage = "gicp";
  writer.on_decision(d);
  CHECK(next.decisions == 1);  // detection goes on while the server is away
  MapWriterStats s = writer.stats();
  CHECK(s.buffered == 5);  // 3 keyframes, the decision and its "published" mark
  CHECK(s.failures == 0);
  // Idle while the server is away: tried again with a backoff, nothing given up.
  idle_until(writer, 1.5, [] { return false; });
  CHECK(writer.stats().retries >= 2);
  CHECK(writer.stats().buffered == 5);

  REQUIRE(server->restart());
  const auto back = std::chrono::steady_clock::now();
  // Within the retry period (1 s) plus the store's reconnect pause (1 s) and slack for a loaded machine.
  REQUIRE(idle_until(writer, 6.0, [&] { return writer.stats().buffered == 0; }));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - back).count();
  INFO("flushed " << seconds << " s after the server was back");
  s = writer.stats();
  CHECK(s.failures == 0);
  CHECK(s.flushed == 5);
  CHECK(s.keyframes_written == 4);
  CHECK(s.decisions_written == 1);
  CHECK(stored(*opened.store).size() == 4);
}
