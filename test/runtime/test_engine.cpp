// The daemon's engine without LCM: load shedding under a burst, and the replay policy that never sheds.
#include <catch2/catch.hpp>

#include <atomic>
#include <random>

#include "loopd/runtime/loopd_engine.hpp"

using namespace loopd;

namespace {
class CountingSink : public EngineSink {
 public:
  void on_decision(const LoopDecision&) override { ++decisions; }
  void on_correction(const CorrectionOutput&) override { ++corrections; }
  std::atomic<int> decisions{0}, corrections{0};
};

/// A small room-like scan (walls, floor, a few boxes): enough structure for features, cheap to compute.
PointCloud room_scan(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  PointCloud c;
  for (int i = 0; i < 6000; ++i) {
    const float a = u(rng), b = u(rng);
    switch (i % 4) {
      case 0:
        c.points.emplace_back(10.f * a, 10.f * b, -1.8f);
        break;  // floor
      case 1:
        c.points.emplace_back(10.f, 10.f * a, 2.f * b);
        break;  // wall
      case 2:
        c.points.emplace_back(10.f * a, -10.f, 2.f * b);
        break;  // wall
      default:
        c.points.emplace_back(3.f + a, 2.f + b, 0.5f * u(rng) - 1.f);
        break;  // box
    }
  }
  return c;
}

StampedPose pose_at(std::int64_t utime, double x) {
  StampedPose p;
  p.utime = utime;
  p.T_world_sensor = make_isometry(x, 0, 0, 0);
  return p;
}

EngineConfig small_config(bool replay) {
  EngineConfig c;
  c.detector.sensor = "vlp16";
  c.num_threads = 2;
  c.queue_capacity = 4;
  c.block_when_full = replay;
  c.detector.m2dp.backend = Backend::kCpu;
  return c;
}
}  // namespace

TEST_CASE("a burst of 100 keyframes sheds the oldest waiting ones, keeps every pose, and counts it") {
  CountingSink sink;
  EngineConfig config = small_config(false);
  LoopdEngine engine(config, &sink);
  for (int i = 0; i < 100; ++i) {
    const std::int64_t t = 1'000'000 + i * 100'000;
    engine.push_pose(pose_at(t, 3.0 * i), 0.0);  // 3 m apart: every scan is a keyframe
    REQUIRE(engine.push_scan(t, room_scan(static_cast<std::uint32_t>(i)), 0.0));
    CHECK(engine.stats().queue_depth <= config.queue_capacity + config.num_threads);  // bounded
  }
  engine.finish();
  const EngineStats s = engine.stats();
  CHECK(s.keyframes == 100);  // every pose is kept in the trajectory
  CHECK(s.shed > 0);          // the burst outran the workers
  CHECK(s.shed < 100);
  CHECK(s.dropped_no_pose == 0);
}

TEST_CASE("the replay policy waits for the workers and sheds nothing") {
  CountingSink sink;
  LoopdEngine engine(small_config(true), &sink);
  for (int i = 0; i < 30; ++i) {
    const std::int64_t t = 1'000'000 + i * 100'000;
    engine.push_pose(pose_at(t, 3.0 * i), 0.0);
    engine.push_scan(t, room_scan(static_cast<std::uint32_t>(i)), 0.0);
  }
  engine.finish();
  const EngineStats s = engine.stats();
  CHECK(s.keyframes == 30);
  CHECK(s.shed == 0);
  CHECK(s.feature_failures == 0);
}

TEST_CASE("poses without scans and scans without poses are bounded and counted") {
  CountingSink sink;
  EngineConfig config = small_config(true);
  config.association.max_poses = 50;
  config.association.max_pending_scans = 8;
  LoopdEngine engine(config, &sink);
  for (int i = 0; i < 500; ++i) engine.push_pose(pose_at(1'000'000 + i * 10'000, 0.01 * i), 0.0);  // no scans
  for (int i = 0; i < 20; ++i) engine.push_scan(100'000'000 + i * 100'000, room_scan(1), 0.0);     // no poses
  engine.finish();
  const EngineStats s = engine.stats();
  CHECK(s.poses_in == 500);
  CHECK(s.scans_in == 20);
  CHECK(s.dropped_no_pose == 20);
  CHECK(s.keyframes == 0);
}
