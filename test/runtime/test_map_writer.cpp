// MapWriter on a real SQLite map: everything is committed before it is passed on; a full disk (SQLite's max_page_count)
// refuses writes, which are counted with the reason while every decision and correction still reaches the next sink.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <thread>
#include <unistd.h>

#include "loopd/store/map_store.hpp"
#include "loopd/runtime/map_writer.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

/// The next sink: records what reached it and whether the map held it at that moment.
struct Recorder : EngineSink {
  MapStore* store = nullptr;
  int decisions = 0, corrections = 0, decisions_on_disk = 0;
  void on_decision(const LoopDecision& d) override {
    ++decisions;
    bool found = false;
    store->for_each_loop(false, [&](LoopDecision&& r) { found = found || r.event_id == d.event_id; });
    decisions_on_disk += found ? 1 : 0;
  }
  void on_correction(const CorrectionOutput&) override { ++corrections; }
};

KeyframeRecord keyframe(std::int64_t index, std::size_t points) {
  KeyframeRecord k;
  k.key = KeyframeKey{0, index};
  k.utime = 1000000 * index;
  k.T_odom_sensor.translation() = Eigen::Vector3d(static_cast<double>(index), 0, 0);
  auto f = std::make_shared<KeyframeFeatures>();
  f->ok = true;
  f->descriptor = Eigen::VectorXf::Constant(192, 0.5f);
  std::uint32_t state = 12345u + static_cast<std::uint32_t>(index);  // incompressible coordinates: the blob stays large
  auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) * 1e-4f;
  };
  for (std::size_t i = 0; i < points; ++i) f->prepared.points.emplace_back(next(), next(), next());
  k.features = f;
  return k;
}

LoopDecision decision(std::int64_t event, std::int64_t query, bool accepted) {
  LoopDecision d;
  d.event_id = event;
  d.query = KeyframeKey{0, query};
  d.match = KeyframeKey{0, 0};
  d.status = accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
  d.stage = accepted ? "accepted" : "gicp";
  return d;
}

}  // namespace

TEST_CASE("map writer: committed before passed on, and a full disk is counted while detection goes on") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_map_writer_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  MapStoreConfig config;
  config.uri = (dir / "map.db").string();
  config.max_pages = 60;  // a few hundred KB: the disk fills after some keyframes
  OpenedMapStore opened = open_map_store(config);
  REQUIRE(opened.status.ok());
  MapStore& store = *opened.store;
  REQUIRE(store.put_session(SessionRecord{}).ok());
  Recorder next;
  next.store = &store;
  MapWriter writer(store, next, 1000);

  int written_before_full = -1;
  for (std::int64_t i = 0; i < 40; ++i) {
    writer.on_keyframe(keyframe(i, 3000), Eigen::Isometry3d::Identity(), nullptr);
    if (writer.stats().failures > 0 && written_before_full < 0) written_before_full = static_cast<int>(i);
    writer.on_decision(decision(i, i, false));
    writer.on_keyframe_decided(KeyframeKey{0, i});
  }
  CorrectionOutput c;
  c.revision = 1;
  c.keys = {KeyframeKey{0, 39}};
  c.T_map_sensor = {Eigen::Isometry3d::Identity()};
  writer.on_correction(c);

  const MapWriterStats s = writer.stats();
  INFO("first refused keyframe: " << written_before_full << ", failures " << s.failures << ": " << s.last_error);
  REQUIRE(written_before_full > 0);  // some keyframes fit, then the disk was full
  CHECK(s.failures > 0);
  CHECK(s.last_error.find("map.db") != std::string::npos);  // the write that stopped the map names it
  CHECK(s.last_error.find("keyframe 0/" + std::to_string(written_before_full)) == 0);
  CHECK(s.keyframes_written == written_before_full);
  // Every decision and the correction reached the next sink: detection went on.
  CHECK(next.decisions == 40);
  CHECK(next.corrections == 1);
  // Those the map took were on disk before they were passed on.
  CHECK(next.decisions_on_disk == s.decisions_written);
  CHECK(next.decisions_on_disk >= written_before_full);
  // What was committed is a consistent prefix: intact, and a restart resumes from it.
  const StoreStatus check = store.check();
  INFO(check.message);
  CHECK(check.ok());
  fs::remove_all(dir);
}

TEST_CASE(
    "map writer: a map locked by another process for a while is written after a pause, locked for longer, its writes wait in memory and reach it "
    "when it is free") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_map_writer_busy_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  MapStoreConfig config;
  config.uri = (dir / "map.db").string();
  config.busy_timeout_ms = 20;  // kBusy quickly, so the writer's own pauses are what waits
  OpenedMapStore opened = open_map_store(config), other = open_map_store(config);
  REQUIRE(opened.status.ok());
  REQUIRE(other.status.ok());
  MapStore& store = *opened.store;
  REQUIRE(store.put_session(SessionRecord{}).ok());
  Recorder next;
  next.store = &store;
  MapWriter writer(store, next, 1000);

  // Another connection holds the write lock for 0.3 s: the first try and the retry after 0.1 s fail, the one after a
  // further 0.4 s goes through.
  REQUIRE(other.store->begin().ok());
  std::thread holder([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    other.store->rollback();
  });
  writer.on_keyframe(keyframe(0, 100), Eigen::Isometry3d::Identity(), nullptr);
  holder.join();
  MapWriterStats s = writer.stats();
  INFO(s.last_error);
  CHECK(s.failures == 0);
  CHECK(s.keyframes_written == 1);
  CHECK(s.busy_retries >= 1);
  CHECK(s.busy_retries <= 3);

  // Held past the inline retries (0.1 + 0.4 s): the decision waits in memory, in order, and is still passed on.
  REQUIRE(other.store->begin().ok());
  writer.set_retry_period(0.5);
  writer.on_decision(decision(1, 0, true));
  s = writer.stats();
  CHECK(s.failures == 0);
  CHECK(s.buffered == 2);  // the decision and its "published" mark
  CHECK(s.busy_retries >= 3);
  CHECK(s.last_error.find("lock") != std::string::npos);
  CHECK(next.decisions == 1);
  // A keyframe made meanwhile queues behind it (never before it: the map stays a consistent prefix).
  writer.on_keyframe(keyframe(1, 100), Eigen::Isometry3d::Identity(), nullptr);
  CHECK(writer.stats().buffered == 3);
  CHECK(writer.stats().keyframes_written == 1);
  // Still locked after a few idle ticks: tried again with a backoff, nothing given up.
  const auto idle_for = [&](double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(seconds * 1000));
    while (std::chrono::steady_clock::now() < until) {
      writer.on_idle();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  };
  idle_for(0.6);
  s = writer.stats();
  CHECK(s.failures == 0);
  CHECK(s.buffered == 3);
  CHECK(s.retries >= 1);
  // The lock released: an idle vehicle's buffer reaches the map within the retry period, with nothing else written.
  other.store->rollback();
  idle_for(0.7);
  s = writer.stats();
  INFO(s.last_error);
  CHECK(s.failures == 0);
  CHECK(s.buffered == 0);
  CHECK(s.flushed == 3);
  CHECK(s.keyframes_written == 2);
  CHECK(s.decisions_written == 1);
  CHECK(s.last_error.empty());
  bool stored = false;
  store.for_each_loop(false, [&](LoopDecision&& r) { stored = stored || (r.event_id == 1 && r.published); });
  CHECK(stored);
  CHECK(store.check().ok());
  fs::remove_all(dir);
}
