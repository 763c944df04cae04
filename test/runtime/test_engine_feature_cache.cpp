// Keyframe features kept in the map store behind a small LRU cache (map.cache_mb) make the same decisions as features
// kept in memory: the cache holds the prepared scans, memory a thin copy with what every query still needs (its
// descriptor and its scene scale: the travel gap and verification settings scale with the scene).
#include <catch2/catch.hpp>

#include <tuple>
#include <vector>

#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "support/block_revisit_drive.hpp"
#include "support/engine_replay.hpp"
#include "support/open_test_map.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

struct Decisions : EngineSink {
  std::vector<std::tuple<std::int64_t, KeyframeKey, KeyframeKey, LoopStatus, std::string>> made;
  void on_decision(const LoopDecision& d) override { made.emplace_back(d.event_id, d.query, d.match, d.status, d.stage); }
  void on_correction(const CorrectionOutput&) override {}
};

}  // namespace

TEST_CASE("engine: features kept in the map behind a 4 MB cache make the same decisions as features in memory") {
  const Drive drive = test::block_revisit_drive();
  Decisions in_memory, cached;
  {
    LoopdEngine engine(test::replay_config(), &in_memory);
    test::replay_drive(engine, drive);
  }
  test::TempDir dir;
  auto store = test::open_test_map(dir.file("map.db"));
  REQUIRE(store->put_session(SessionRecord{}).ok());
  {
    MapWriter writer(*store, cached, 100);
    LoopdEngine engine(test::replay_config(), &writer);
    engine.keep_features_in_store(*store, 4u << 20);  // a few keyframes: nearly every candidate is read back
    REQUIRE(engine.resume(*store, false).ok);
    test::replay_drive(engine, drive);
    REQUIRE(writer.flush(5.0));
    CHECK(engine.stats().cached_feature_bytes <= 4 << 20);
  }
  REQUIRE(in_memory.made.size() > 50);
  CHECK(cached.made == in_memory.made);
}
