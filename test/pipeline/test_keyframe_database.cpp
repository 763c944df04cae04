// KeyframeDatabase: records by key (never by position), insertion order kept, memory counted.
#include <catch2/catch.hpp>
#include <memory>

#include "loopd/pipeline/keyframe_database.hpp"

using namespace loopd;

namespace {
KeyframeRecord record(SessionId session, std::int64_t index, std::size_t points) {
  KeyframeRecord r;
  r.key = KeyframeKey{session, index};
  r.utime = 1000 * index + session;
  if (points > 0) {
    auto f = std::make_shared<KeyframeFeatures>();
    f->ok = true;
    f->prepared.points.resize(points);
    r.features = f;
  }
  return r;
}
}  // namespace

TEST_CASE("keyframe database finds records by key, whatever order and sessions they came in") {
  KeyframeDatabase db;
  // Two sessions interleaved, and indices that do not start at 0: a key is not a position.
  db.add(record(1, 100, 10));
  db.add(record(0, 7, 0));  // shed: no features
  db.add(record(1, 101, 20));
  REQUIRE(db.size() == 3u);
  const KeyframeRecord* r = db.find(KeyframeKey{1, 101});
  REQUIRE(r != nullptr);
  CHECK(r->utime == 101001);
  REQUIRE(r->features);
  CHECK(r->features->prepared.points.size() == 20u);
  REQUIRE(db.find(KeyframeKey{0, 7}) != nullptr);
  CHECK_FALSE(db.find(KeyframeKey{0, 7})->features);
  CHECK(db.find(KeyframeKey{0, 100}) == nullptr);  // same index, other session
  CHECK(db.find(KeyframeKey{1, 0}) == nullptr);
  CHECK(db.newest().key == KeyframeKey{1, 101});
  CHECK(db.records()[1].key == KeyframeKey{0, 7});
}

TEST_CASE("keyframe database counts the memory its records hold") {
  KeyframeDatabase db;
  CHECK(db.bytes_per_keyframe() == 0u);
  db.add(record(0, 0, 1000));
  db.add(record(0, 1, 3000));
  const std::size_t points = 2000 * sizeof(Eigen::Vector3f);  // mean of 1000 and 3000 points
  CHECK(db.bytes_per_keyframe() >= points);
  CHECK(db.bytes_per_keyframe() < points + 4096);
}
