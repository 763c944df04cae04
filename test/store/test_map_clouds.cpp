// Keyframe map clouds in the SQLite map: written with their keyframe, read back by key, counted, removed with an
// undecided keyframe, and an older map gains the table on a writable open.
#include <sqlite3.h>

#include <catch2/catch.hpp>
#include <memory>

#include "loopd/store/map_cloud_codec.hpp"
#include "loopd/store/map_store.hpp"
#include "loopd/store/sqlite/sqlite_map_store.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;
using Code = StoreStatus::Code;

namespace {

#define REQUIRE_OK(expr)                              \
  do {                                                \
    const StoreStatus st_ = (expr);                   \
    INFO(to_string(st_.code) << ": " << st_.message); \
    REQUIRE(st_.ok());                                \
  } while (0)

std::unique_ptr<MapStore> open_map(const std::string& uri, bool read_only = false, StoreStatus* status = nullptr) {
  MapStoreConfig config;
  config.uri = uri;
  config.read_only = read_only;
  OpenedMapStore opened = open_map_store(config);
  if (status) *status = opened.status;
  return std::move(opened.store);
}

/// A cloud of n points on a small helix, intensity rising.
PointCloud helix(int n) {
  PointCloud c;
  for (int i = 0; i < n; ++i) {
    const double a = 0.05 * i;
    c.points.emplace_back(static_cast<float>(8.0 * std::cos(a)), static_cast<float>(8.0 * std::sin(a)), static_cast<float>(0.01 * i));
    c.intensity.push_back(static_cast<float>(i % 100));
  }
  return c;
}

MapKeyframe keyframe(std::int64_t index, int cloud_points) {
  MapKeyframe k;
  k.record.key = KeyframeKey{0, index};
  k.record.utime = 1700000000000000 + 100000 * index;
  k.record.T_odom_sensor.translation() = Eigen::Vector3d(static_cast<double>(index), 0.0, 0.0);
  k.T_map_sensor = k.record.T_odom_sensor;
  if (cloud_points > 0) k.map_cloud = std::make_shared<const std::vector<std::uint8_t>>(encode_map_cloud(helix(cloud_points), 0.01));
  return k;
}

void put_session0(MapStore& store) {
  SessionRecord s;
  s.sensor = "hdl64";
  s.source = "test";
  REQUIRE_OK(store.put_session(s));
}

}  // namespace

TEST_CASE("map clouds: written with the keyframe, read back by key, counted in the stats") {
  test::TempDir dir;
  auto store = open_map(dir.file("map.db"));
  REQUIRE(store);
  put_session0(*store);
  REQUIRE_OK(store->put_keyframe(keyframe(0, 500)));
  REQUIRE_OK(store->put_keyframe(keyframe(1, 0)));  // shed: no map cloud
  REQUIRE_OK(store->put_keyframe(keyframe(2, 800)));
  const StoreResult<PointCloud> got = store->get_map_cloud({0, 2});
  REQUIRE(got.ok());
  CHECK(got.value.size() == 800);
  const DecodedMapCloud want = decode_map_cloud(encode_map_cloud(helix(800), 0.01));
  REQUIRE(want.ok);
  for (std::size_t i = 0; i < want.cloud.size(); ++i) REQUIRE(got.value.points[i] == want.cloud.points[i]);
  const StoreResult<PointCloud> none = store->get_map_cloud({0, 1});
  CHECK(none.status.code == Code::kNotFound);
  CHECK(none.status.message.find("keyframe 0/1 has no map cloud") != std::string::npos);
  CHECK(store->get_map_cloud({0, 7}).status.code == Code::kNotFound);
  const StoreResult<MapStats> stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.map_clouds == 2);
  CHECK(stats.value.map_cloud_points == 1300);
  CHECK(stats.value.map_cloud_bytes > 0);
  CHECK(store->check().ok());
  // A repeated key is success with the same keyframe (a retried write), refused with another, and either way the
  // first keyframe's cloud stays as it was.
  CHECK(store->put_keyframe(keyframe(2, 100)).ok());
  MapKeyframe moved = keyframe(2, 100);
  moved.record.T_odom_sensor.translation().x() += 0.5;
  CHECK_FALSE(store->put_keyframe(moved).ok());
  CHECK(store->get_map_cloud({0, 2}).value.size() == 800);
  store.reset();
  auto reader = open_map(dir.file("map.db"), true);
  REQUIRE(reader);
  CHECK(reader->get_map_cloud({0, 0}).value.size() == 500);
}

TEST_CASE("map clouds: drop_undecided removes the clouds of the keyframes it removes") {
  test::TempDir dir;
  auto store = open_map(dir.file("map.db"));
  REQUIRE(store);
  put_session0(*store);
  for (int i = 0; i < 3; ++i) REQUIRE_OK(store->put_keyframe(keyframe(i, 100)));
  REQUIRE_OK(store->mark_decided({0, 0}));
  const StoreResult<std::int64_t> dropped = store->drop_undecided();
  REQUIRE(dropped.ok());
  CHECK(dropped.value == 2);
  CHECK(store->get_map_cloud({0, 0}).ok());
  CHECK(store->get_map_cloud({0, 1}).status.code == Code::kNotFound);
  CHECK(store->stats().value.map_clouds == 1);
}

TEST_CASE(
    "map clouds: a schema 2 map gains the map_clouds table, scan fingerprints, published marks, measured steps, the loop ledger and "
    "retired keyframes on a writable open, read-only it is refused with the versions") {
  test::TempDir dir;
  const std::string path = dir.file("map.db");
  {
    auto store = open_map(path);
    REQUIRE(store);
    put_session0(*store);
    REQUIRE_OK(store->put_keyframe(keyframe(0, 0)));
  }
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(path.c_str(), &db) == SQLITE_OK);
  REQUIRE(sqlite3_exec(db,
                       "DROP TABLE map_clouds; ALTER TABLE keyframes DROP COLUMN scan_fingerprint; ALTER TABLE keyframes DROP COLUMN step; "
                       "ALTER TABLE loops DROP COLUMN published; DROP TABLE loop_ledger; ALTER TABLE correction DROP COLUMN ledger_seq; "
                       "ALTER TABLE keyframes DROP COLUMN retired; "
                       "PRAGMA user_version = 2;",
                       nullptr, nullptr, nullptr) == SQLITE_OK);
  sqlite3_close(db);
  StoreStatus status;
  CHECK_FALSE(open_map(path, true, &status));
  CHECK(status.message.find("schema version 2, this loopd reads " + std::to_string(kSqliteMapSchemaVersion)) != std::string::npos);
  auto store = open_map(path, false, &status);
  INFO(status.message);
  REQUIRE(store);
  CHECK(store->get_map_cloud({0, 0}).status.code == Code::kNotFound);  // stored before map clouds
  MapKeyframe fingerprinted = keyframe(1, 50);
  fingerprinted.record.scan_fingerprint = 0xfedcba9876543210ull;  // above INT64_MAX: stored as its two's complement
  MeasuredStep step;
  step.T_previous_this.translation() = Eigen::Vector3d(2.0, 0.1, -0.01);
  step.T_previous_this.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  for (int k = 0; k < 36; ++k) step.information(k % 6, k / 6) = 1.0 + k / 7.0;
  fingerprinted.record.step = step;
  REQUIRE_OK(store->put_keyframe(fingerprinted));
  CHECK(store->get_map_cloud({0, 1}).value.size() == 50);
  std::vector<std::uint64_t> fingerprints;
  REQUIRE_OK(store->for_each_keyframe(0, KeyframeLoad::kPose, [&](MapKeyframe&& k) { fingerprints.push_back(k.record.scan_fingerprint); }));
  CHECK(fingerprints == std::vector<std::uint64_t>{0, 0xfedcba9876543210ull});  // 0: stored before fingerprints
  std::vector<std::optional<MeasuredStep>> steps;
  REQUIRE_OK(store->for_each_keyframe(0, KeyframeLoad::kFull, [&](MapKeyframe&& k) { steps.push_back(k.record.step); }));
  REQUIRE(steps.size() == 2);
  CHECK_FALSE(steps[0]);  // stored before measured steps: the odometry's step
  REQUIRE(steps[1]);
  CHECK(steps[1]->T_previous_this.matrix() == step.T_previous_this.matrix());  // bit for bit
  CHECK(steps[1]->information == step.information);
  LoopDecision loop;
  loop.event_id = 3;
  loop.query = {0, 1};
  loop.match = {0, 0};
  loop.status = LoopStatus::kRejected;
  loop.stage = "gicp";
  REQUIRE_OK(store->put_loop(loop));
  bool published = true;
  REQUIRE_OK(store->for_each_loop(false, [&](LoopDecision&& r) { published = r.published; }));
  CHECK_FALSE(published);  // stored, not yet on the bus
  REQUIRE_OK(store->mark_published(3));
  REQUIRE_OK(store->for_each_loop(false, [&](LoopDecision&& r) { published = r.published; }));
  CHECK(published);
  // The ledger exists now: a rejected decision cannot be revoked, and nothing is in it.
  LoopLedgerEntry revoke;
  revoke.event_id = 3;
  CHECK(store->put_ledger_entry(revoke).status.code == Code::kInvalid);
  const auto ledger = store->loop_ledger();
  REQUIRE(ledger.ok());
  CHECK(ledger.value.empty());
  // Retired keyframes exist now: none before, one after it is retired (its map cloud gone with its features).
  CHECK(store->stats().value.keyframes_retired == 0);
  REQUIRE_OK(store->retire_keyframes({{0, 1}}));
  CHECK(store->stats().value.keyframes_retired == 1);
  CHECK(store->get_map_cloud({0, 1}).status.code == Code::kNotFound);
  CHECK(store->check().ok());
}
