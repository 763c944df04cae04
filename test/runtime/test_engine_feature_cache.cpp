// Keyframe features kept in the map store behind a small LRU cache (map.cache_mb) make the same decisions as features
// kept in memory: the cache holds the prepared scans, memory a thin copy with what every query still needs (its
// descriptor and its scene scale: the travel gap and verification settings scale with the scene).
#include <catch2/catch.hpp>

#include <tuple>
#include <vector>

#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "support/block_revisit_drive.hpp"
#include "support/open_test_map.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

struct Decisions : EngineSink {
  std::vector<std::tuple<std::int64_t, KeyframeKey, KeyframeKey, LoopStatus, std::string>> made;
  void on_decision(const LoopDecision& d) override { made.emplace_back(d.event_id, d.query, d.match, d.status, d.stage); }
  void on_correction(const CorrectionOutput&) override {}
};

EngineConfig drive_config() {
  EngineConfig c;
  c.detector.sensor = "vlp16";
  c.num_threads = 2;
  c.block_when_full = true;  // replay: nothing is shed
  c.detector.m2dp.backend = Backend::kCpu;
  return c;
}

void replay(LoopdEngine& engine, const Drive& drive) {
  for (const DriveScan& s : drive.scans) {
    const double arrival = static_cast<double>(s.utime) * 1e-6;
    engine.push_pose(s.odometry, arrival);
    REQUIRE(engine.push_scan(s.utime, drive.simulate(s.index, 2), arrival));
  }
  engine.finish();
}

}  // namespace

TEST_CASE("engine: features kept in the map behind a 4 MB cache make the same decisions as features in memory") {
  const Drive drive = test::block_revisit_drive();
  Decisions in_memory, cached;
  {
    LoopdEngine engine(drive_config(), &in_memory);
    replay(engine, drive);
  }
  test::TempDir dir;
  auto store = test::open_test_map(dir.file("map.db"));
  REQUIRE(store->put_session(SessionRecord{}).ok());
  {
    MapWriter writer(*store, cached, 100);
    LoopdEngine engine(drive_config(), &writer);
    engine.keep_features_in_store(*store, 4u << 20);  // a few keyframes: nearly every candidate is read back
    REQUIRE(engine.resume(*store, false).ok);
    replay(engine, drive);
    REQUIRE(writer.flush(5.0));
    CHECK(engine.stats().cached_feature_bytes <= 4 << 20);
  }
  REQUIRE(in_memory.made.size() > 50);
  CHECK(cached.made == in_memory.made);
}
