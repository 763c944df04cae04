// The map store on PostgreSQL (scripts/pg-local: a server on a unix socket, ctest's fixture shared by every case or
// else one of the process's own, and a fresh database per test case; the restart case stops a server of its own): the same exact round trips as the
// SQLite map, transactions, the schema version, two vehicles on one map, the solver lock, joint corrections, a server restart, and connections that
// cannot be made. Skipped with a warning when the PostgreSQL server binaries are not installed.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <memory>
#include <thread>

#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/store/postgres/postgres_connection.hpp"
#include "loopd/store/postgres/postgres_map_store.hpp"
#include "loopd/store/shared_map.hpp"
#include "loopd/records/vehicle_sessions.hpp"
#include "map_store_records.hpp"
#include "map_test_scene.hpp"
#include "support/postgres_server.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;
using namespace loopd::map_test;
using Code = StoreStatus::Code;

namespace {

constexpr const char* kPassword = "loopdtest1";

/// @brief True when `server` runs; else WARNs (the binaries are missing: skip) or FAILs.
bool usable(test::PostgresServer& server, bool started) {
  if (started) return true;
  if (server.binaries_missing()) {
    WARN("skipped: " << server.reason());
    return false;
  }
  FAIL("the PostgreSQL test server did not start: " << server.reason());
  return false;
}

/// @brief The shared server: ctest's fixture (test/CMakeLists.txt) when it runs, else one of this process's own,
/// started at the first use (null: skip).
test::PostgresServer* server() {
  static test::PostgresServer instance(kPassword);
#ifdef LOOPD_TEST_POSTGRES_DIR
  static const bool started = instance.attach(LOOPD_TEST_POSTGRES_DIR) || instance.start();
#else
  static const bool started = instance.start();
#endif
  return usable(instance, started) ? &instance : nullptr;
}

/// @brief A fresh map on `s` (empty string: skip): a schema of its own, named for this process (the fixture's server
/// is shared), so no database is copied per case.
std::string fresh_database(test::PostgresServer* s = server()) {
  static int maps = 0;
  if (!s) return "";
  const std::string uri = s->create_schema("map_" + std::to_string(::getpid()) + "_" + std::to_string(++maps));
  INFO(s->reason());
  REQUIRE(!uri.empty());
  return uri;
}

OpenedMapStore open_store(const std::string& uri, int vehicle = -1, bool read_only = false) {
  MapStoreConfig config;
  config.uri = uri;
  config.vehicle = vehicle;
  config.read_only = read_only;
  return open_map_store(config);
}

std::unique_ptr<MapStore> open_ok(const std::string& uri, int vehicle = -1) {
  OpenedMapStore opened = open_store(uri, vehicle);
  INFO(to_string(opened.status.code) << ": " << opened.status.message);
  REQUIRE(opened.status.ok());
  REQUIRE(opened.store);
  REQUIRE(opened.store->shared() != nullptr);
  return std::move(opened.store);
}

/// @brief Retries `write` for up to 5 s (the store reconnects at most once a second) until it succeeds.
StoreStatus eventually(const std::function<StoreStatus()>& write) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  StoreStatus st = write();
  while (!st.ok() && st.code == Code::kUnavailable && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    st = write();
  }
  return st;
}

MapKeyframe with_cloud(MapKeyframe k, int points) {
  PointCloud cloud;
  for (int i = 0; i < points; ++i) cloud.points.emplace_back(0.01f * static_cast<float>(i), std::sin(0.1f * static_cast<float>(i)), 0.5f);
  k.map_cloud = std::make_shared<const std::vector<std::uint8_t>>(encode_map_cloud(cloud, 0.01));
  return k;
}

SessionId session_of(int vehicle, int k = 0) { return vehicle * kSessionsPerVehicle + k; }

}  // namespace

TEST_CASE("postgres map: keyframes, map clouds, loops and the correction round-trip exactly", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto store = open_ok(uri);
  std::map<std::pair<SessionId, std::int64_t>, MapKeyframe> written;
  fill(*store, &written);
  for (KeyframeLoad depth : {KeyframeLoad::kPose, KeyframeLoad::kDescriptor, KeyframeLoad::kFull}) {
    const std::vector<MapKeyframe> all = load(*store, std::nullopt, depth);
    REQUIRE(all.size() == 6);
    for (std::size_t n = 0; n < all.size(); ++n) {
      const MapKeyframe& got = all[n];
      INFO("depth " << static_cast<int>(depth) << ", keyframe " << to_string(got.record.key));
      CHECK(got.record.key == KeyframeKey{static_cast<SessionId>(n / 3), static_cast<std::int64_t>(n % 3)});
      const MapKeyframe& want = written.at({got.record.key.session, got.record.key.index});
      CHECK(got.record.utime == want.record.utime);
      CHECK(same_pose(got.record.T_odom_sensor, want.record.T_odom_sensor));
      CHECK(same_pose(got.T_map_sensor, want.T_map_sensor));
      CHECK(same_bits(got.record.residual, want.record.residual));
      CHECK(same_bits(got.record.travelled, want.record.travelled));
      REQUIRE(got.record.step.has_value() == want.record.step.has_value());
      if (want.record.step) {
        CHECK(same_pose(got.record.step->T_previous_this, want.record.step->T_previous_this));
        CHECK(got.record.step->information == want.record.step->information);
      }
      if (depth == KeyframeLoad::kPose || !want.record.features) {
        CHECK(got.record.features == nullptr);
        continue;
      }
      REQUIRE(got.record.features);
      require_same_feature_fields(*want.record.features, *got.record.features);
      if (depth == KeyframeLoad::kFull) require_same_prepared(want.record.features->prepared, got.record.features->prepared);
      if (depth == KeyframeLoad::kDescriptor) CHECK(got.record.features->prepared.points.empty());
    }
  }
  CHECK(load(*store, SessionId{1}, KeyframeLoad::kPose).size() == 3);
  const StoreResult<PreparedScan> prepared = store->get_prepared(KeyframeKey{1, 2});
  REQUIRE(prepared.ok());
  require_same_prepared(written.at({1, 2}).record.features->prepared, prepared.value);
  const auto shed = store->get_prepared(KeyframeKey{1, 1});
  CHECK(shed.status.code == Code::kNotFound);
  CHECK(shed.status.message.find("keyframe 1/1 has no features") != std::string::npos);
  CHECK(store->get_prepared(KeyframeKey{0, 99}).status.message.find("no keyframe 0/99") != std::string::npos);

  const MapKeyframe clouded = with_cloud(keyframe(1, 3, nullptr), 700);
  REQUIRE_OK(store->put_keyframe(clouded));
  const auto cloud = store->get_map_cloud(KeyframeKey{1, 3});
  REQUIRE(cloud.ok());
  const DecodedMapCloud want_cloud = decode_map_cloud(clouded.map_cloud->data(), clouded.map_cloud->size());
  REQUIRE(want_cloud.ok);
  CHECK(same_points(cloud.value.points, want_cloud.cloud.points));
  CHECK(store->get_map_cloud(KeyframeKey{1, 2}).status.code == Code::kNotFound);

  const std::vector<LoopDecision> loops_written = {loop(4, {0, 2}, {0, 0}, true), loop(5, {1, 2}, {0, 1}, false), loop(9, {1, 2}, {0, 2}, true)};
  for (const LoopDecision& l : loops_written) REQUIRE_OK(store->put_loop(l));
  REQUIRE_OK(store->put_loop(loops_written[0]));  // the same content again: a write retried after a lost acknowledgement
  LoopDecision changed = loops_written[0];
  changed.match.index = 1;
  const StoreStatus refused = store->put_loop(changed);
  CHECK(refused.code == Code::kInvalid);
  CHECK(refused.message.find("already stored with other content") != std::string::npos);
  const std::vector<LoopDecision> all_loops = loops(*store, false);
  REQUIRE(all_loops.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) require_same_loop(loops_written[i], all_loops[i]);
  CHECK(loops(*store, true).size() == 2);

  CorrectionRecord c;
  c.revision = 2;
  c.loop_event_id = 9;
  c.method = "pose_graph";
  c.T_map_odom = pose(0.3, 0.02);
  for (std::int64_t i = 0; i < 3; ++i) {
    c.keys.push_back({0, i});
    c.T_map_sensor.push_back(pose(static_cast<double>(i), 0.05 * static_cast<double>(i)));
  }
  c.corrector_state = {0, 1, 2, 255, 7};
  REQUIRE_OK(store->put_correction(c));
  const auto got = store->correction();
  REQUIRE(got.ok());
  REQUIRE(got.value.has_value());
  CHECK(got.value->revision == 2);
  CHECK(got.value->method == "pose_graph");
  CHECK(same_pose(got.value->T_map_odom, c.T_map_odom));
  REQUIRE(got.value->keys.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) CHECK((got.value->keys[i] == c.keys[i] && same_pose(got.value->T_map_sensor[i], c.T_map_sensor[i])));
  CHECK(got.value->corrector_state == c.corrector_state);

  const auto stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.sessions == 2);
  CHECK(stats.value.keyframes == 7);
  CHECK(stats.value.loops_accepted == 2);
  CHECK(stats.value.loops_rejected == 1);
  CHECK(stats.value.map_clouds == 1);
  CHECK(stats.value.map_cloud_points == 700);
  CHECK(stats.value.bytes > 0);
  REQUIRE_OK(store->check());
}

TEST_CASE("postgres map: retired keyframes as on SQLite, and a vehicle retires only its own", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto whole = open_ok(uri);
  fill(*whole);
  check_retire_keyframes(*whole);
  auto two = open_ok(uri, 2);
  const StoreStatus other = two->retire_keyframes({{0, 0}});  // vehicle 0's session, not vehicle 2's
  INFO(other.message);
  CHECK(other.code == StoreStatus::Code::kNotFound);
  CHECK(whole->stats().value.keyframes_retired == 2);
}

TEST_CASE("postgres map: the loop ledger as on SQLite, and each vehicle sees its own loops' entries", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto whole = open_ok(uri);
  fill(*whole);
  check_loop_ledger(*whole);
  // Vehicles 1 and 2 both number their events from 0: an entry names the vehicle whose loop it is about.
  auto one = open_ok(uri, 1), two = open_ok(uri, 2);
  const SessionId s1 = first_session_of(1), s2 = first_session_of(2);
  for (auto* v : {one.get(), two.get()}) {
    const SessionId s = v == one.get() ? s1 : s2;
    REQUIRE_OK(v->put_session(session(s)));
    REQUIRE_OK(v->put_keyframe(keyframe(s, 0, nullptr)));
    REQUIRE_OK(v->put_keyframe(keyframe(s, 1, nullptr)));
    REQUIRE_OK(v->put_loop(loop(7, {s, 1}, {s, 0}, true)));
  }
  LoopLedgerEntry e;
  e.event_id = 7;
  e.who = "fleet operator";
  CHECK(whole->put_ledger_entry(e).status.code == Code::kInvalid);  // two vehicles hold event 7: ambiguous unscoped
  const StoreResult<std::int64_t> put = two->put_ledger_entry(e);
  REQUIRE_OK(put.status);
  const auto seen_by_one = one->loop_ledger(), seen_by_two = two->loop_ledger();
  REQUIRE_OK(seen_by_one.status);
  REQUIRE_OK(seen_by_two.status);
  CHECK(seen_by_one.value.empty());
  REQUIRE(seen_by_two.value.size() == 1);
  CHECK(seen_by_two.value[0].seq == put.value);
  CHECK(one->stats().value.loops_revoked == 0);
  CHECK(two->stats().value.loops_revoked == 1);
  // The fleet's joint graph leaves the revoked loop out, and its counts move with the ledger (the solver solves again).
  for (auto* v : {one.get(), two.get()})
    for (std::int64_t i : {0, 1}) REQUIRE_OK(v->mark_decided({v == one.get() ? s1 : s2, i}));
  std::vector<KeyframeKey> fleet_loop_queries;
  REQUIRE_OK(whole->shared()->for_each_fleet_loop([&](LoopDecision&& l) {
    if (l.event_id == 7) fleet_loop_queries.push_back(l.query);
  }));
  CHECK(fleet_loop_queries == std::vector<KeyframeKey>{{s1, 1}});
  const auto counts = whole->shared()->fleet_counts();
  REQUIRE_OK(counts.status);
  CHECK(counts.value.ledger_seq == put.value);
  CHECK(one->put_ledger_entry(e).ok());  // vehicle 1's event 7 is a loop of its own
}

TEST_CASE("postgres map: keyframes are read in batches, in key order, each once", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto store = open_ok(uri, 4);
  REQUIRE_OK(store->begin());
  for (int k : {0, 1}) {
    REQUIRE_OK(store->put_session(session(session_of(4, k))));
    for (std::int64_t i = 0; i < 150; ++i) REQUIRE_OK(store->put_keyframe(keyframe(session_of(4, k), i, nullptr)));
  }
  REQUIRE_OK(store->commit());
  for (KeyframeLoad depth : {KeyframeLoad::kPose, KeyframeLoad::kFull}) {  // kFull reads 128 a batch
    const std::vector<MapKeyframe> all = load(*store, std::nullopt, depth);
    REQUIRE(all.size() == 300);
    for (std::size_t n = 0; n < all.size(); ++n)
      REQUIRE(all[n].record.key == KeyframeKey{session_of(4, static_cast<int>(n / 150)), static_cast<std::int64_t>(n % 150)});
  }
}

TEST_CASE("postgres map: check() finds loops, corrections and indices that break the map's invariants", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto store = open_ok(uri);
  REQUIRE_OK(store->put_session(session(0)));
  for (std::int64_t i : {0, 1, 3}) REQUIRE_OK(store->put_keyframe(keyframe(0, i, nullptr)));
  REQUIRE_OK(store->put_loop(loop(1, {0, 3}, {0, 7}, true)));
  CorrectionRecord c;
  c.keys = {{0, 0}, {2, 5}};
  c.T_map_sensor = {pose(0, 0), pose(1, 0)};
  REQUIRE_OK(store->put_correction(c));
  const StoreStatus st = store->check();
  INFO(st.message);
  CHECK(st.code == Code::kCorrupt);
  CHECK(st.message.find("fails its check (3 problems)") != std::string::npos);
  CHECK(st.message.find("loop event 1 (vehicle 0) names keyframe 0/7, which is not stored") != std::string::npos);
  CHECK(st.message.find("session 0: keyframe indices are not 0..2 (min 0, max 3)") != std::string::npos);
  CHECK(st.message.find("correction revision 0 names keyframe 2/5, which is not stored") != std::string::npos);
}

TEST_CASE("postgres map: an aborted transaction leaves nothing, reopening sees everything, another schema is refused", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  {
    auto store = open_ok(uri);
    REQUIRE_OK(store->begin());
    REQUIRE_OK(store->put_session(session(0)));
    REQUIRE_OK(store->put_keyframe(keyframe(0, 0, scan_features(0))));
    REQUIRE_OK(store->rollback());
    CHECK(store->stats().value.keyframes == 0);
    REQUIRE_OK(store->begin());
    fill(*store);
    REQUIRE_OK(store->commit());
    CHECK(store->commit().code == Code::kInvalid);
    // A statement that fails inside a transaction aborts it on the server: commit says so instead of kOk.
    REQUIRE_OK(store->begin());
    REQUIRE_OK(store->put_session(session(7)));
    MapKeyframe repeated = keyframe(0, 0, nullptr);
    repeated.record.utime += 1;
    CHECK(store->put_keyframe(repeated).code == Code::kInvalid);                 // a repeated key with other content
    CHECK(store->put_keyframe(keyframe(7, 0, nullptr)).code == Code::kInvalid);  // refused until rollback
    const StoreStatus refused = store->commit();
    CHECK(refused.code == Code::kInvalid);
    CHECK(refused.message.find("rolled back") != std::string::npos);
    CHECK(store->stats().value.sessions == 2);
  }
  OpenedMapStore reader = open_store(uri, -1, true);
  REQUIRE(reader.status.ok());
  CHECK(load(*reader.store, std::nullopt, KeyframeLoad::kFull).size() == 6);
  CHECK(reader.store->put_session(session(5)).code != Code::kOk);  // read-only transactions

  // A database without loopd's tables is refused read-only (nothing is created).
  const std::string empty = fresh_database();
  const OpenedMapStore none = open_store(empty, -1, true);
  CHECK(none.status.code == Code::kNotFound);
  CHECK(none.status.message.find("no loopd map") != std::string::npos);

  REQUIRE(server()->sql(uri, "UPDATE loopd_meta SET value = '99' WHERE key = 'schema_version'"));
  const OpenedMapStore refused = open_store(uri);
  CHECK(refused.status.code == Code::kCorrupt);
  CHECK(refused.status.message.find("schema version 99") != std::string::npos);
  CHECK(refused.status.message.find("reads " + std::to_string(kPostgresMapSchemaVersion)) != std::string::npos);
}

TEST_CASE("postgres map: a write waiting for another transaction's lock gives kBusy after busy_timeout_ms", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto holder = open_ok(uri, 1);
  MapStoreConfig config;
  config.uri = uri;
  config.vehicle = 1;
  config.busy_timeout_ms = 200;
  OpenedMapStore waiter = open_map_store(config);
  REQUIRE(waiter.status.ok());
  REQUIRE_OK(holder->begin());
  REQUIRE_OK(holder->put_session(session(session_of(1))));
  const auto t0 = std::chrono::steady_clock::now();
  const StoreStatus busy = waiter.store->put_session(session(session_of(1)));  // the same row: waits for holder
  const double waited_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  INFO(busy.message);
  CHECK(busy.code == Code::kBusy);
  CHECK(waited_ms >= 150);
  CHECK(waited_ms < 3000);
  REQUIRE_OK(holder->commit());
  REQUIRE_OK(waiter.store->put_session(session(session_of(1))));
}

TEST_CASE("postgres map: several processes creating the schema of a new database at once all succeed", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  std::vector<StoreStatus> statuses(4);
  std::vector<std::thread> openers;
  for (std::size_t i = 0; i < statuses.size(); ++i) openers.emplace_back([&, i] { statuses[i] = open_store(uri, static_cast<int>(i)).status; });
  for (std::thread& t : openers) t.join();
  for (const StoreStatus& st : statuses) {
    INFO(st.message);
    CHECK(st.ok());
  }
}

TEST_CASE("postgres map: two vehicles on one map each see their own verbs and the other's decided keyframes", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto one = open_ok(uri, 1), two = open_ok(uri, 2);
  for (auto [store, vehicle] : {std::pair{one.get(), 1}, {two.get(), 2}}) {
    REQUIRE_OK(store->put_session(session(session_of(vehicle))));
    for (std::int64_t i = 0; i < 4; ++i) REQUIRE_OK(store->put_keyframe(keyframe(session_of(vehicle), i, scan_features(static_cast<int>(i)))));
    for (std::int64_t i = 0; i < vehicle + 1; ++i) REQUIRE_OK(store->mark_decided({session_of(vehicle), i}));
    // Both number their events from 0: no collision.
    REQUIRE_OK(store->put_loop(loop(0, {session_of(vehicle), 1}, {session_of(vehicle), 0}, true)));
    REQUIRE_OK(store->put_loop(loop(1, {session_of(vehicle), 3}, {session_of(vehicle), 0}, false)));
    CorrectionRecord c;
    c.revision = vehicle;
    c.loop_event_id = 1;  // made by the decision of keyframe 3 (undecided for vehicle 1 until drop_undecided)
    REQUIRE_OK(store->put_correction(c));
  }
  CHECK(loops(*one, false).size() == 2);
  CHECK(loops(*two, false).size() == 2);
  CHECK(load(*one, std::nullopt, KeyframeLoad::kPose).size() == 4);
  CHECK(one->correction().value->revision == 1);
  CHECK(two->correction().value->revision == 2);
  CHECK(one->stats().value.keyframes == 4);

  std::map<SessionId, std::int64_t> seen;
  std::vector<MapKeyframe> remote;
  REQUIRE_OK(one->shared()->for_each_new_remote_keyframe(seen, KeyframeLoad::kDescriptor, [&](MapKeyframe&& k) { remote.push_back(std::move(k)); }));
  REQUIRE(remote.size() == 3);  // vehicle 2 decided 0..2
  for (std::size_t i = 0; i < 3; ++i) CHECK((remote[i].record.key == KeyframeKey{session_of(2), static_cast<std::int64_t>(i)}));
  CHECK(remote[0].record.features != nullptr);
  CHECK(seen.at(session_of(2)) == 2);
  remote.clear();
  REQUIRE_OK(one->shared()->for_each_new_remote_keyframe(seen, KeyframeLoad::kPose, [&](MapKeyframe&& k) { remote.push_back(std::move(k)); }));
  CHECK(remote.empty());
  REQUIRE_OK(two->mark_decided({session_of(2), 3}));
  REQUIRE_OK(one->shared()->for_each_new_remote_keyframe(seen, KeyframeLoad::kPose, [&](MapKeyframe&& k) { remote.push_back(std::move(k)); }));
  REQUIRE(remote.size() == 1);
  CHECK(remote[0].record.key.index == 3);

  // Vehicle 1 drops its undecided keyframes (2, 3) and the decision keyframe 3 made; vehicle 2's are untouched.
  const auto dropped = one->drop_undecided();
  REQUIRE(dropped.ok());
  CHECK(dropped.value == 2);
  CHECK(loops(*one, false).size() == 1);
  CHECK(loops(*two, false).size() == 2);
  CHECK(load(*two, std::nullopt, KeyframeLoad::kPose).size() == 4);
  CHECK_FALSE(one->correction().value.has_value());  // made by a dropped decision
  CHECK(two->correction().value->revision == 2);

  auto whole = open_ok(uri);
  CHECK(loops(*whole, false).size() == 3);
  std::vector<LoopDecision> fleet_loops;
  REQUIRE_OK(whole->shared()->for_each_fleet_loop([&](LoopDecision&& l) { fleet_loops.push_back(std::move(l)); }));
  CHECK(fleet_loops.size() == 2);  // both accepted loops name decided keyframes
  std::vector<MapKeyframe> fleet_keyframes;
  REQUIRE_OK(whole->shared()->for_each_fleet_keyframe([&](MapKeyframe&& k) { fleet_keyframes.push_back(std::move(k)); }));
  REQUIRE(fleet_keyframes.size() == 6);  // vehicle 1: 0, 1; vehicle 2: 0 .. 3
  CHECK(fleet_keyframes.front().record.key == KeyframeKey{session_of(1), 0});
  CHECK(fleet_keyframes.back().record.key == KeyframeKey{session_of(2), 3});
  CHECK(fleet_keyframes.front().record.features == nullptr);
  const auto counts = whole->shared()->fleet_counts();
  REQUIRE(counts.ok());
  CHECK(counts.value.keyframes == 6);
  CHECK(counts.value.loops_accepted == 2);
  REQUIRE_OK(whole->check());
}

TEST_CASE("postgres map: the solver lock is held by one connection and passes on when it closes", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto a = open_ok(uri, 1), b = open_ok(uri, 2);
  const auto a_takes = a->shared()->hold_solver_lock();
  REQUIRE(a_takes.ok());
  CHECK(a_takes.value);
  CHECK(a->shared()->hold_solver_lock().value);
  const auto b_asks = b->shared()->hold_solver_lock();
  REQUIRE(b_asks.ok());
  CHECK_FALSE(b_asks.value);
  a.reset();
  bool taken = false;
  for (int i = 0; i < 50 && !taken; ++i) {  // the server ends a's session a moment after the socket closes
    const auto asked = b->shared()->hold_solver_lock();
    INFO(asked.status.message);
    taken = asked.value;
    if (!taken) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  CHECK(taken);
}

TEST_CASE("postgres map: joint corrections are numbered, read back exactly, and only newer ones are returned", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  auto store = open_ok(uri, 3);
  SharedMap& fleet = *store->shared();
  CHECK_FALSE(fleet.fleet_correction(0).value.has_value());
  FleetCorrectionRecord c;
  c.solver_vehicle = 3;
  c.loops = 12;
  c.solved_utime = 1700000000123456;
  for (std::int64_t i = 0; i < 5; ++i) {
    c.keys.push_back({session_of(3), i});
    c.T_map_sensor.push_back(pose(static_cast<double>(i), 0.1));
    c.utimes.push_back(1000 + i);
  }
  c.sessions.push_back({session_of(3), true, pose(1.0, 0.2), 5});
  const auto first = fleet.put_fleet_correction(c);
  const auto second = fleet.put_fleet_correction(c);
  INFO(first.status.message);
  REQUIRE(first.ok());
  REQUIRE(second.ok());
  CHECK(second.value == first.value + 1);
  const auto newest = fleet.fleet_correction(0);
  REQUIRE(newest.ok());
  REQUIRE(newest.value.has_value());
  CHECK(newest.value->revision == second.value);
  CHECK(newest.value->solver_vehicle == 3);
  CHECK(newest.value->loops == 12);
  CHECK(newest.value->solved_utime == c.solved_utime);
  REQUIRE(newest.value->keys.size() == 5);
  for (std::size_t i = 0; i < 5; ++i)
    CHECK((newest.value->keys[i] == c.keys[i] && same_pose(newest.value->T_map_sensor[i], c.T_map_sensor[i]) &&
           newest.value->utimes[i] == c.utimes[i]));
  REQUIRE(newest.value->sessions.size() == 1);
  CHECK(newest.value->sessions[0].anchored);
  CHECK(same_pose(newest.value->sessions[0].T_map_session, c.sessions[0].T_map_session));
  CHECK(newest.value->sessions[0].keyframes == 5);
  const auto none = fleet.fleet_correction(second.value);
  REQUIRE(none.ok());
  CHECK_FALSE(none.value.has_value());
  CHECK(fleet.fleet_counts().value.newest_revision == second.value);

  // Only the newest 20 revisions stay; a record whose arrays differ in number is refused.
  for (int i = 0; i < 20; ++i) REQUIRE(fleet.put_fleet_correction(c).ok());
  REQUIRE(server()->sql(uri, "DO $$ BEGIN IF (SELECT count(*) FROM fleet_corrections) <> 20 THEN RAISE 'kept revisions'; END IF; END $$"));
  c.utimes.pop_back();
  CHECK(fleet.put_fleet_correction(c).status.code == Code::kInvalid);
}

TEST_CASE("postgres map: writes while the server is down (stopped or crashed) are kUnavailable, then succeed after it restarts", "[postgres]") {
  const std::string mode = GENERATE("fast", "immediate");  // immediate: as a crash, what was committed must survive
  INFO("stop --mode " << mode);
  // Not the shared server (the other cases run meanwhile); one for both modes (its first checkpoint is the slow one).
  static test::PostgresServer own(kPassword);
  static const bool started = own.start();
  if (!usable(own, started)) return;
  const std::string uri = fresh_database(&own);
  if (uri.empty()) return;
  auto store = open_ok(uri, 1);
  REQUIRE_OK(store->put_session(session(session_of(1))));
  REQUIRE_OK(store->put_keyframe(keyframe(session_of(1), 0, scan_features(0))));
  REQUIRE(store->shared()->hold_solver_lock().value);
  REQUIRE_OK(store->begin());
  REQUIRE_OK(store->put_keyframe(keyframe(session_of(1), 1, nullptr)));

  REQUIRE(own.stop(mode));
  const StoreStatus in_transaction = store->put_keyframe(keyframe(session_of(1), 2, nullptr));
  INFO(in_transaction.message);
  CHECK(in_transaction.code == Code::kUnavailable);
  CHECK(store->commit().code == Code::kUnavailable);
  for (int i = 0; i < 3; ++i) {
    const StoreStatus down = store->put_keyframe(keyframe(session_of(1), 1, nullptr));
    INFO(down.message);
    CHECK(down.code == Code::kUnavailable);
    CHECK(down.message.find(kPassword) == std::string::npos);
  }
  CHECK(store->shared()->hold_solver_lock().status.code == Code::kUnavailable);

  REQUIRE(own.restart());
  REQUIRE_OK(eventually([&] { return store->put_keyframe(keyframe(session_of(1), 1, nullptr)); }));
  REQUIRE_OK(store->put_keyframe(keyframe(session_of(1), 2, nullptr)));
  const std::vector<MapKeyframe> all = load(*store, std::nullopt, KeyframeLoad::kFull);
  REQUIRE(all.size() == 3);
  CHECK(all[0].record.features != nullptr);               // written before the restart
  const auto lock = store->shared()->hold_solver_lock();  // lost with the connection, taken again
  REQUIRE(lock.ok());
  CHECK(lock.value);
}

TEST_CASE("postgres map: a wrong password or a socket with no server fails at open with a clear message", "[postgres]") {
  const std::string uri = fresh_database();
  if (uri.empty()) return;
  const OpenedMapStore wrong = open_store(server()->uri_with_password("notthepassword"));
  CHECK(wrong.store == nullptr);
  CHECK(wrong.status.code == Code::kInvalid);
  INFO(wrong.status.message);
  CHECK(wrong.status.message.find("password authentication failed") != std::string::npos);
  CHECK(wrong.status.message.find("notthepassword") == std::string::npos);
  CHECK(wrong.status.message.find("postgresql://loopd:***@/loopd?host=") != std::string::npos);

  test::TempDir nobody_there("loopd_pg_none");
  const OpenedMapStore unreachable = open_store("postgresql://loopd:" + std::string(kPassword) + "@/loopd?host=" + nobody_there.path());
  CHECK(unreachable.store == nullptr);
  CHECK(unreachable.status.code == Code::kUnavailable);
  INFO(unreachable.status.message);
  CHECK(unreachable.status.message.find("cannot connect") != std::string::npos);
  CHECK(unreachable.status.message.find(nobody_there.path()) != std::string::npos);
  CHECK(unreachable.status.message.find(kPassword) == std::string::npos);

  const OpenedMapStore no_database = open_store(server()->uri_with_password(kPassword, "no_such_map"));
  CHECK(no_database.status.code == Code::kInvalid);
  CHECK(no_database.status.message.find("does not exist") != std::string::npos);
}

TEST_CASE("postgres map: connection defaults are added where the URI sets none, the password is masked in messages", "[postgres]") {
  const std::string set = postgres::with_connection_defaults("postgresql://u:pw@/db?host=/x&connect_timeout=2");
  CHECK(set.find("connect_timeout=2") != std::string::npos);
  CHECK(set.find("connect_timeout=5") == std::string::npos);
  CHECK(set.find("&keepalives_idle=10") != std::string::npos);
  const std::string bare = postgres::with_connection_defaults("postgresql://db.example/fleet");
  CHECK(bare.rfind("postgresql://db.example/fleet?connect_timeout=5&keepalives_idle=10", 0) == 0);
  CHECK(mask_password("postgresql://loopd:secret@/loopd?host=/tmp/x") == "postgresql://loopd:***@/loopd?host=/tmp/x");
  CHECK(mask_password("postgresql://loopd@/loopd?host=/tmp/x") == "postgresql://loopd@/loopd?host=/tmp/x");
  CHECK(mask_password("postgres://host:5432/db") == "postgres://host:5432/db");
  CHECK(mask_password("postgresql://u:pw@db:5432/fleet") == "postgresql://u:***@db:5432/fleet");
  CHECK(mask_password("postgresql:///fleet?host=/x&password=secret&sslmode=disable") == "postgresql:///fleet?host=/x&password=***&sslmode=disable");
}
