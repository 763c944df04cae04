// The map store on each back end (sqlite::memory:, an SQLite file, sqlite://FILE): exact round trips of sessions,
// keyframes at every load depth, loops and the correction; transactions; reopening; and the damaged maps, bad paths
// and full disks that must give a status with a reason, never a crash.
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>

#include "loopd/store/map_store.hpp"
#include "loopd/store/sqlite/sqlite_map_store.hpp"
#include "map_store_records.hpp"
#include "map_test_scene.hpp"

using namespace loopd;
using namespace loopd::map_test;
namespace fs = std::filesystem;
using Code = StoreStatus::Code;

namespace {

/// @brief A fresh temp folder, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/loopd_map_test_XXXXXX";
    path_ = ::mkdtemp(pattern.data()) ? pattern : std::string();
    REQUIRE(!path_.empty());
  }
  ~TempDir() {
    std::error_code ec;
    fs::permissions(path_, fs::perms::owner_all, ec);
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// @brief The URI of a back end: "memory", "file" (a plain path) or "sqlite-uri" (sqlite://path).
std::string uri_of(const std::string& backend, const TempDir& dir) {
  if (backend == "memory") return "sqlite::memory:";
  if (backend == "file") return dir.file("map.db");
  return "sqlite://" + dir.file("map.db");
}

std::unique_ptr<MapStore> open_ok(const std::string& uri, const std::string& synchronous = "normal") {
  MapStoreConfig config;
  config.uri = uri;
  config.synchronous = synchronous;
  OpenedMapStore opened = open_map_store(config);
  INFO(opened.status.message);
  REQUIRE(opened.status.ok());
  REQUIRE(opened.store);
  return std::move(opened.store);
}

StoreStatus open_status(const std::string& uri, bool read_only = false) {
  MapStoreConfig config;
  config.uri = uri;
  config.read_only = read_only;
  const OpenedMapStore opened = open_map_store(config);
  CHECK(opened.store == nullptr);
  return opened.status;
}

void set_user_version(const std::string& path, int version) {
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  const std::string sql = "PRAGMA user_version = " + std::to_string(version);
  CHECK(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
}

}  // namespace

TEST_CASE("map store: keyframes round-trip exactly at every load depth, per session") {
  const std::string backend = GENERATE("memory", "file", "sqlite-uri");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  std::map<std::pair<SessionId, std::int64_t>, MapKeyframe> written;
  fill(*store, &written);

  for (KeyframeLoad depth : {KeyframeLoad::kPose, KeyframeLoad::kDescriptor, KeyframeLoad::kFull}) {
    const std::vector<MapKeyframe> all = load(*store, std::nullopt, depth);
    REQUIRE(all.size() == 6);
    for (std::size_t n = 0; n < all.size(); ++n) {
      const MapKeyframe& got = all[n];
      INFO("depth " << static_cast<int>(depth) << ", keyframe " << to_string(got.record.key));
      CHECK(got.record.key == KeyframeKey{static_cast<SessionId>(n / 3), static_cast<std::int64_t>(n % 3)});  // key order
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
      if (depth == KeyframeLoad::kDescriptor) {
        CHECK(got.record.features->prepared.points.empty());
        CHECK(got.record.features->prepared.segmentation.clusters.empty());
      } else {
        require_same_prepared(want.record.features->prepared, got.record.features->prepared);
      }
    }
  }
  const std::vector<MapKeyframe> second = load(*store, SessionId{1}, KeyframeLoad::kPose);
  REQUIRE(second.size() == 3);
  for (const MapKeyframe& k : second) CHECK(k.record.key.session == 1);
  CHECK(load(*store, SessionId{7}, KeyframeLoad::kPose).empty());

  const StoreResult<PreparedScan> prepared = store->get_prepared(KeyframeKey{1, 2});
  REQUIRE(prepared.ok());
  require_same_prepared(written.at({1, 2}).record.features->prepared, prepared.value);
  const auto shed = store->get_prepared(KeyframeKey{1, 1});
  CHECK(shed.status.code == Code::kNotFound);
  CHECK(shed.status.message.find("keyframe 1/1 has no features") != std::string::npos);
  CHECK(store->get_prepared(KeyframeKey{0, 99}).status.code == Code::kNotFound);

  const auto sessions = store->sessions();
  REQUIRE(sessions.ok());
  REQUIRE(sessions.value.size() == 2);
  for (const SessionRecord& s : sessions.value) {
    const SessionRecord want = session(s.id);
    CHECK(s.first_utime == want.first_utime);
    CHECK(s.sensor == want.sensor);
    CHECK(s.source == want.source);
    CHECK(same_pose(s.T_map_session, want.T_map_session));
    CHECK(s.anchored == want.anchored);
  }
  // put_session replaces (an anchored session keeps its keyframes).
  SessionRecord anchored = session(1);
  anchored.anchored = true;
  anchored.T_map_session = pose(-4.0, 0.7);
  REQUIRE_OK(store->put_session(anchored));
  const auto after = store->sessions();
  REQUIRE(after.ok());
  CHECK(after.value[1].anchored);
  CHECK(same_pose(after.value[1].T_map_session, anchored.T_map_session));
  CHECK(load(*store, SessionId{1}, KeyframeLoad::kPose).size() == 3);
  REQUIRE_OK(store->check());
}

TEST_CASE("map store: loop decisions and the correction round-trip exactly, the newest correction replaces the last") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  fill(*store);
  const std::vector<LoopDecision> written = {loop(4, {0, 2}, {0, 0}, true), loop(5, {1, 2}, {0, 1}, false), loop(9, {1, 2}, {0, 2}, true)};
  for (const LoopDecision& l : written) REQUIRE_OK(store->put_loop(l));
  REQUIRE_OK(store->put_loop(written[0]));  // stored already with the same content: a retried write
  LoopDecision other = written[0];
  other.status = LoopStatus::kCandidate;
  const StoreStatus duplicate = store->put_loop(other);
  CHECK(duplicate.code == Code::kInvalid);
  CHECK(duplicate.message.find("put loop event 4") != std::string::npos);
  CHECK(duplicate.message.find("already stored with other content") != std::string::npos);

  const std::vector<LoopDecision> all = loops(*store, false);
  REQUIRE(all.size() == 3);
  for (std::size_t i = 0; i < 3; ++i) require_same_loop(written[i], all[i]);
  const std::vector<LoopDecision> accepted = loops(*store, true);
  REQUIRE(accepted.size() == 2);
  CHECK(accepted[0].event_id == 4);
  CHECK(accepted[1].event_id == 9);

  const auto none = store->correction();
  REQUIRE(none.ok());
  CHECK_FALSE(none.value.has_value());
  CorrectionRecord c;
  c.revision = 1;
  c.loop_event_id = 4;
  c.method = "pose_graph";
  c.T_map_odom = pose(0.3, 0.02);
  for (SessionId s : {0, 1})
    for (std::int64_t i = 0; i < 3; ++i) {
      c.keys.push_back({s, i});
      c.T_map_sensor.push_back(pose(static_cast<double>(i) + 0.1 * s, 0.05 * static_cast<double>(i)));
    }
  c.corrector_state = {0, 1, 2, 255, 7};
  REQUIRE_OK(store->put_correction(c));
  c.revision = 2;
  c.loop_event_id = 9;
  c.T_map_sensor[3] = pose(-8.0, 1.0);
  REQUIRE_OK(store->put_correction(c));
  const auto got = store->correction();
  REQUIRE(got.ok());
  REQUIRE(got.value.has_value());
  CHECK(got.value->revision == 2);
  CHECK(got.value->loop_event_id == 9);
  CHECK(got.value->method == "pose_graph");
  CHECK(same_pose(got.value->T_map_odom, c.T_map_odom));
  REQUIRE(got.value->keys.size() == c.keys.size());
  for (std::size_t i = 0; i < c.keys.size(); ++i) {
    CHECK(got.value->keys[i] == c.keys[i]);
    CHECK(same_pose(got.value->T_map_sensor[i], c.T_map_sensor[i]));
  }
  CHECK(got.value->corrector_state == c.corrector_state);
  c.T_map_sensor.pop_back();
  CHECK(store->put_correction(c).code == Code::kInvalid);

  const auto stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.sessions == 2);
  CHECK(stats.value.keyframes == 6);
  CHECK(stats.value.loops_accepted == 2);
  CHECK(stats.value.loops_rejected == 1);
  CHECK(stats.value.bytes > 5 * 60000);  // five feature blobs of ~80 KB
  REQUIRE_OK(store->check());
}

TEST_CASE("map store: the loop ledger keeps every revoke and restore in order and refuses changes that change nothing") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  fill(*store);
  check_loop_ledger(*store);
}

TEST_CASE("map store: retired keyframes keep their pose rows and lose their features and map clouds") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  fill(*store);
  check_retire_keyframes(*store);
}

TEST_CASE("map store: a file map reopens with everything in it, read-only too") {
  TempDir dir;
  const std::string path = dir.file("map.db");
  std::map<std::pair<SessionId, std::int64_t>, MapKeyframe> written;
  {
    auto store = open_ok(path, "full");
    fill(*store, &written);
    REQUIRE_OK(store->put_loop(loop(1, {0, 2}, {0, 0}, true)));
  }
  CHECK_FALSE(fs::exists(path + "-wal"));  // the last connection checkpointed and removed the log
  auto store = open_ok("sqlite://" + path);
  const std::vector<MapKeyframe> all = load(*store, std::nullopt, KeyframeLoad::kFull);
  REQUIRE(all.size() == 6);
  require_same_prepared(written.at({0, 1}).record.features->prepared, all[1].record.features->prepared);
  CHECK(loops(*store, true).size() == 1);
  // A second session after the restart continues the map.
  REQUIRE_OK(store->put_session(session(2)));
  REQUIRE_OK(store->put_keyframe(keyframe(2, 0, nullptr)));
  store.reset();

  MapStoreConfig config;
  config.uri = path;
  config.read_only = true;
  OpenedMapStore ro = open_map_store(config);
  INFO(ro.status.message);
  REQUIRE(ro.status.ok());
  CHECK(load(*ro.store, std::nullopt, KeyframeLoad::kPose).size() == 7);
  const StoreStatus refused = ro.store->put_session(session(3));
  CHECK(refused.code == Code::kIo);
  CHECK(refused.message.find(path) != std::string::npos);
  REQUIRE_OK(ro.store->check());
}

TEST_CASE("map store: a map of another schema version is refused with the versions in the message") {
  TempDir dir;
  const std::string path = dir.file("map.db");
  open_ok(path).reset();
  set_user_version(path, 99);
  const StoreStatus st = open_status(path);
  CHECK(st.code == Code::kCorrupt);
  CHECK(st.message == "map " + path + " has schema version 99, this loopd reads " + std::to_string(kSqliteMapSchemaVersion));
  // Refused before anything was written: the version is still 99.
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  REQUIRE(sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &stmt, nullptr) == SQLITE_OK);
  REQUIRE(sqlite3_step(stmt) == SQLITE_ROW);
  CHECK(sqlite3_column_int(stmt, 0) == 99);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

TEST_CASE("map store: a rolled back transaction leaves nothing, a committed one everything") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  REQUIRE_OK(store->begin());
  REQUIRE_OK(store->put_session(session(0)));
  REQUIRE_OK(store->put_keyframe(keyframe(0, 0, scan_features(0))));
  REQUIRE_OK(store->put_loop(loop(1, {0, 0}, {0, 0}, false)));
  REQUIRE_OK(store->rollback());
  auto stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.sessions == 0);
  CHECK(stats.value.keyframes == 0);
  CHECK(stats.value.loops_rejected == 0);

  REQUIRE_OK(store->begin());
  REQUIRE_OK(store->put_session(session(0)));
  REQUIRE_OK(store->put_keyframe(keyframe(0, 0, nullptr)));
  REQUIRE_OK(store->commit());
  stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.keyframes == 1);
  CHECK(store->commit().code == Code::kInvalid);  // no transaction open
}

TEST_CASE("map store: two sessions with the same indices do not collide, a repeated key or an unknown session is refused") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  REQUIRE_OK(store->put_session(session(0)));
  REQUIRE_OK(store->put_session(session(1)));
  REQUIRE_OK(store->put_keyframe(keyframe(0, 0, nullptr)));
  MapKeyframe other = keyframe(1, 0, nullptr);
  other.record.utime = 42;
  REQUIRE_OK(store->put_keyframe(other));
  const auto all = load(*store, std::nullopt, KeyframeLoad::kPose);
  REQUIRE(all.size() == 2);
  CHECK(all[0].record.utime != 42);
  CHECK(all[1].record.utime == 42);
  // The same keyframe again (a write retried after its commit went through) is success and stores nothing new; the
  // key with other content is refused.
  REQUIRE_OK(store->put_keyframe(other));
  const StoreStatus again = store->put_keyframe(keyframe(1, 0, nullptr));
  CHECK(again.code == Code::kInvalid);
  CHECK(again.message.find("put keyframe 1/0") != std::string::npos);
  CHECK(again.message.find("already stored with other content") != std::string::npos);
  const StoreStatus orphan = store->put_keyframe(keyframe(5, 0, nullptr));
  CHECK(orphan.code == Code::kInvalid);
  CHECK(orphan.message.find("FOREIGN KEY") != std::string::npos);
  CHECK(load(*store, std::nullopt, KeyframeLoad::kPose).size() == 2);
}

TEST_CASE("map store: check() finds loops, corrections and indices that break the map's invariants") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  auto store = open_ok(uri_of(backend, dir));
  REQUIRE_OK(store->put_session(session(0)));
  for (std::int64_t i : {0, 1, 3}) REQUIRE_OK(store->put_keyframe(keyframe(0, i, nullptr)));
  REQUIRE_OK(store->put_loop(loop(1, {0, 3}, {0, 7}, true)));
  CorrectionRecord c;
  c.keys = {{0, 0}, {2, 5}};
  c.T_map_sensor = {pose(0, 0), pose(1, 0)};
  REQUIRE_OK(store->put_correction(c));
  const StoreStatus st = store->check();
  CHECK(st.code == Code::kCorrupt);
  CHECK(st.message.find("fails its check (3 problems)") != std::string::npos);
  CHECK(st.message.find("loop event 1 names keyframe 0/7, which is not stored") != std::string::npos);
  CHECK(st.message.find("session 0: keyframe indices are not 0..2 (min 0, max 3)") != std::string::npos);
  CHECK(st.message.find("correction revision 0 names keyframe 2/5, which is not stored") != std::string::npos);
}

TEST_CASE("map store: drop_undecided removes the keyframes a stop cut off, their decisions and their correction") {
  TempDir dir;
  auto store = open_ok(dir.file("map.db"));
  REQUIRE_OK(store->put_session(session(0)));
  for (std::int64_t i = 0; i < 5; ++i) REQUIRE_OK(store->put_keyframe(keyframe(0, i, scan_features(static_cast<int>(i)))));
  for (std::int64_t i = 0; i < 3; ++i) REQUIRE_OK(store->mark_decided({0, i}));
  CHECK(store->mark_decided({0, 9}).code == Code::kNotFound);
  REQUIRE_OK(store->put_loop(loop(1, {0, 2}, {0, 0}, true)));
  REQUIRE_OK(store->put_loop(loop(2, {0, 4}, {0, 1}, true)));
  REQUIRE_OK(store->put_loop(loop(3, {0, 3}, {0, 0}, false)));
  CorrectionRecord c;
  c.loop_event_id = 2;
  REQUIRE_OK(store->put_correction(c));
  const auto dropped = store->drop_undecided();
  REQUIRE(dropped.ok());
  CHECK(dropped.value == 2);
  CHECK(load(*store, std::nullopt, KeyframeLoad::kPose).size() == 3);
  const auto left = loops(*store, false);
  REQUIRE(left.size() == 1);
  CHECK(left[0].event_id == 1);
  const auto correction = store->correction();
  REQUIRE(correction.ok());
  CHECK_FALSE(correction.value.has_value());
  REQUIRE_OK(store->check());
  const auto again = store->drop_undecided();
  REQUIRE(again.ok());
  CHECK(again.value == 0);
}

TEST_CASE("map store: a truncated file, a garbage file and a foreign database are refused as corrupt, not a crash") {
  TempDir dir;
  const std::string path = dir.file("map.db");
  {
    auto store = open_ok(path);
    fill(*store);
  }
  const auto size = fs::file_size(path);
  REQUIRE(size > 100000);
  SECTION("truncated to half") {
    fs::resize_file(path, size / 2);
    const StoreStatus st = open_status(path);
    CHECK(st.code == Code::kCorrupt);
    CHECK(st.message.find("map " + path + " is truncated") == 0);
  }
  SECTION("truncated inside the header") {
    fs::resize_file(path, 60);
    const StoreStatus st = open_status(path);
    CHECK(st.code == Code::kCorrupt);
    CHECK(st.message.find("shorter than an SQLite header") != std::string::npos);
  }
  SECTION("garbage") {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << std::string(8192, 'x');
    const StoreStatus st = open_status(path);
    CHECK(st.code == Code::kCorrupt);
    CHECK(st.message.find(path) != std::string::npos);
  }
  SECTION("a damaged page: the open may pass, reading and check() give kCorrupt") {
    {
      std::fstream f(path, std::ios::binary | std::ios::in | std::ios::out);
      f.seekp(static_cast<std::streamoff>(size / 2));
      const std::string junk(4096, '\xA5');
      f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
    }
    MapStoreConfig config;
    config.uri = path;
    OpenedMapStore opened = open_map_store(config);
    if (opened.status.ok()) {
      bool any_failure = false;
      const StoreStatus read = opened.store->for_each_keyframe(std::nullopt, KeyframeLoad::kFull, [](MapKeyframe&&) {});
      if (!read.ok()) {
        CHECK(read.code == Code::kCorrupt);
        any_failure = true;
      }
      const StoreStatus check = opened.store->check();
      CHECK(check.code == Code::kCorrupt);
      any_failure = any_failure || !check.ok();
      CHECK(any_failure);
    } else {
      CHECK(opened.status.code == Code::kCorrupt);
    }
  }
  SECTION("an SQLite database that is not a loopd map") {
    fs::remove(path);
    sqlite3* db = nullptr;
    REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
    CHECK(sqlite3_exec(db, "CREATE TABLE t (x)", nullptr, nullptr, nullptr) == SQLITE_OK);
    sqlite3_close(db);
    const StoreStatus st = open_status(path);
    CHECK(st.code == Code::kCorrupt);
    CHECK(st.message.find("not a loopd map") != std::string::npos);
  }
}

TEST_CASE("map store: a path that cannot be written gives kIo at open") {
  TempDir dir;
  SECTION("a read-only folder") {
    const std::string ro = dir.file("ro");
    fs::create_directory(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    if (::geteuid() == 0) {
      WARN("running as root: a read-only folder is writable; a folder under a regular file stands in for it");
      std::ofstream(dir.file("plain")) << "x";
      const StoreStatus st = open_status(dir.file("plain") + "/map.db");
      CHECK(st.code == Code::kIo);
      CHECK(st.message.find(dir.file("plain") + "/map.db") != std::string::npos);
    } else {
      const StoreStatus st = open_status(ro + "/map.db");
      CHECK(st.code == Code::kIo);
      CHECK(st.message.find(ro + "/map.db") != std::string::npos);
    }
  }
  SECTION("read-only open of a missing map") {
    const StoreStatus st = open_status(dir.file("missing.db"), true);
    CHECK(st.code == Code::kIo);
    CHECK(st.message.find("missing.db: cannot open") != std::string::npos);
  }
}

TEST_CASE("map store: a full disk (max_page_count) makes put_keyframe fail with kIo, what was stored stays readable") {
  const std::string backend = GENERATE("memory", "file");
  INFO("back end " << backend);
  TempDir dir;
  MapStoreConfig config;
  config.uri = uri_of(backend, dir);
  config.max_pages = 80;  // 320 KiB: room for a few keyframes
  OpenedMapStore opened = open_map_store(config);
  REQUIRE(opened.status.ok());
  MapStore& store = *opened.store;
  REQUIRE_OK(store.put_session(session(0)));
  StoreStatus failed;
  std::int64_t stored = 0;
  const auto features = scan_features(0);
  for (std::int64_t i = 0; i < 20 && failed.ok(); ++i) {
    failed = store.put_keyframe(keyframe(0, i, features));
    if (failed.ok()) ++stored;
  }
  INFO(failed.message);
  CHECK(failed.code == Code::kIo);
  CHECK(failed.message.find("put keyframe 0/" + std::to_string(stored)) != std::string::npos);
  CHECK(failed.message.find("full") != std::string::npos);
  CHECK(stored >= 1);
  const auto all = load(store, std::nullopt, KeyframeLoad::kFull);
  CHECK(static_cast<std::int64_t>(all.size()) == stored);
  REQUIRE_OK(store.check());
  // A small record still fits where a keyframe does not: the store works on.
  REQUIRE_OK(store.put_keyframe(keyframe(0, stored, nullptr)));
}

TEST_CASE("map store: a write while another connection holds the lock gives kBusy after busy_timeout_ms") {
  TempDir dir;
  const std::string path = dir.file("map.db");
  auto holder = open_ok(path);
  MapStoreConfig config;
  config.uri = path;
  config.busy_timeout_ms = 50;
  OpenedMapStore other = open_map_store(config);
  REQUIRE(other.status.ok());
  REQUIRE_OK(holder->begin());
  REQUIRE_OK(holder->put_session(session(0)));
  const StoreStatus busy = other.store->put_session(session(1));
  CHECK(busy.code == Code::kBusy);
  CHECK(busy.message.find(path) != std::string::npos);
  REQUIRE_OK(holder->commit());
  REQUIRE_OK(other.store->put_session(session(1)));
  const auto sessions = other.store->sessions();
  REQUIRE(sessions.ok());
  CHECK(sessions.value.size() == 2);
}

TEST_CASE("map store: URIs and settings that cannot work are refused with kInvalid") {
  for (const auto& [uri, text] :
       std::vector<std::pair<std::string, std::string>>{{"redis://x", "unknown scheme"}, {"", "map uri is empty"}, {"sqlite://", "names no file"}}) {
    INFO(uri);
    const StoreStatus st = open_status(uri);
    CHECK(st.code == Code::kInvalid);
    CHECK(st.message.find(text) != std::string::npos);
  }
  MapStoreConfig config;
  config.uri = "sqlite::memory:";
  config.synchronous = "off";
  const OpenedMapStore opened = open_map_store(config);
  CHECK(opened.status.code == Code::kInvalid);
  CHECK(opened.status.message.find("synchronous") != std::string::npos);
}

TEST_CASE("map store: after a kill -9, committed records are there and an open transaction left nothing") {
  TempDir dir;
  const std::string path = dir.file("map.db");
  const auto features = scan_features(3);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    // No Catch assertions in the child: it writes, then dies without closing anything.
    MapStoreConfig config;
    config.uri = path;
    OpenedMapStore opened = open_map_store(config);
    if (!opened.status.ok()) ::_exit(2);
    MapStore& store = *opened.store;
    bool ok = store.put_session(session(0)).ok();
    for (std::int64_t i = 0; i < 3; ++i) ok = ok && store.put_keyframe(keyframe(0, i, features)).ok();
    ok = ok && store.put_loop(loop(1, {0, 2}, {0, 0}, true)).ok();
    ok = ok && store.begin().ok() && store.put_keyframe(keyframe(0, 3, features)).ok() && store.put_loop(loop(2, {0, 3}, {0, 0}, true)).ok();
    if (!ok) ::_exit(3);
    ::raise(SIGKILL);
    ::_exit(4);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGKILL);
  CHECK(fs::file_size(path + "-wal") > 0);  // the committed records are only in the write-ahead log
  auto store = open_ok(path);
  const auto all = load(*store, std::nullopt, KeyframeLoad::kFull);
  REQUIRE(all.size() == 3);
  require_same_prepared(features->prepared, all[2].record.features->prepared);
  const auto left = loops(*store, false);
  REQUIRE(left.size() == 1);
  CHECK(left[0].event_id == 1);
  REQUIRE_OK(store->check());
}
