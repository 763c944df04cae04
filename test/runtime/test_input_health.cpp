// Input health: clock jumps, scan loss, odometry resets and sensor changes, each with known input.
#include <catch2/catch.hpp>

#include <random>

#include "loopd/runtime/clock_watch.hpp"
#include "loopd/runtime/odometry_reset_filter.hpp"
#include "loopd/runtime/scan_loss_estimator.hpp"
#include "loopd/runtime/sensor_layout_watch.hpp"

using namespace loopd;

namespace {
constexpr std::int64_t kPeriod = 100000;  // 10 Hz [us]
}

TEST_CASE("clock watch: in order, duplicates and small reordering are stale, jumps are followed and counted") {
  ClockWatch w;
  CHECK(w.check(1'000'000, 100.0) == ClockVerdict::kInOrder);
  CHECK(w.check(1'100'000, 100.1) == ClockVerdict::kInOrder);
  CHECK(w.check(1'100'000, 100.1) == ClockVerdict::kStale);   // duplicate
  CHECK(w.check(1'050'000, 100.12) == ClockVerdict::kStale);  // reordered datagram
  CHECK(w.check(1'200'000, 100.2) == ClockVerdict::kInOrder);
  // A 5 s gap in both clocks (the sensor was off) is not a jump.
  CHECK(w.check(6'200'000, 105.2) == ClockVerdict::kInOrder);
  // Backwards by 60 s: the first such message is held back, the second confirms the new time line.
  CHECK(w.check(-53'700'000, 105.3) == ClockVerdict::kStale);
  CHECK(w.check(-53'600'000, 105.4) == ClockVerdict::kJumpBack);
  CHECK(w.check(-53'500'000, 105.5) == ClockVerdict::kInOrder);
  // Forward by an hour.
  CHECK(w.check(3'546'500'000, 105.6) == ClockVerdict::kJumpForward);
  CHECK(w.jumps() == 2);
}

TEST_CASE("clock watch: one bogus far-future stamp costs two messages, then the real time line is back") {
  ClockWatch w;
  std::int64_t t = 0;
  double arrival = 0.0;
  for (int i = 0; i < 10; ++i) CHECK(w.check(t += kPeriod, arrival += 0.1) == ClockVerdict::kInOrder);
  CHECK(w.check(INT64_MAX, arrival += 0.1) == ClockVerdict::kJumpForward);
  CHECK(w.check(t += kPeriod, arrival += 0.1) == ClockVerdict::kStale);
  CHECK(w.check(t += kPeriod, arrival += 0.1) == ClockVerdict::kJumpBack);
  CHECK(w.check(t += kPeriod, arrival += 0.1) == ClockVerdict::kInOrder);
  CHECK(w.last_utime() == t);
}

TEST_CASE("scan loss estimate: no loss on a steady stream, the true count under 10 % and 50 % random loss and a burst") {
  SECTION("steady 10 Hz: none") {
    ScanLossEstimator e;
    for (int i = 0; i < 500; ++i) e.on_scan(i * kPeriod + (i % 3) * 500);  // 0.5 ms jitter
    CHECK(e.lost() == 0);
    CHECK(e.period_us() == Approx(kPeriod).margin(1000));
  }
  for (double rate : {0.1, 0.5}) {
    ScanLossEstimator e;
    std::mt19937 rng(3);
    std::bernoulli_distribution lose(rate);
    int lost = 0;
    for (int i = 0; i < 2000; ++i) {
      if (i > 0 && i < 1999 && lose(rng)) {
        ++lost;
        continue;
      }
      e.on_scan(i * kPeriod);
    }
    INFO("loss rate " << rate << ", lost " << lost << ", estimated " << e.lost());
    // The first few intervals come before the period is known; everything after is counted exactly.
    CHECK(e.lost() <= lost);
    CHECK(e.lost() >= lost * 0.97);
    CHECK(e.loss_fraction() == Approx(static_cast<double>(e.lost()) / (e.received() + e.lost())));
  }
  SECTION("a burst of 30 lost scans and poses going on without scans") {
    ScanLossEstimator e;
    for (int i = 0; i < 100; ++i) e.on_scan(i * kPeriod);
    for (int i = 130; i < 200; ++i) e.on_scan(i * kPeriod);
    CHECK(e.lost() == 30);
    for (int i = 200; i < 220; ++i) e.on_pose(i * kPeriod);  // scans stopped after 199, odometry did not
    CHECK(e.lost() == 30 + 20);
    CHECK(e.loss_fraction() == Approx(50.0 / 220.0));
  }
  SECTION("95 % lost (a receive buffer far too small): the odometry gives the period, every lost scan is counted") {
    for (int poses_per_scan : {1, 10}) {  // odometry at the scan rate, and 100 Hz odometry with a 10 Hz lidar
      ScanLossEstimator e;
      std::mt19937 rng(5);
      std::bernoulli_distribution arrives(0.05);
      int received = 0;
      for (int i = 0; i < 300; ++i) {
        for (int k = 0; k < poses_per_scan; ++k) e.on_pose(i * kPeriod + k * (kPeriod / poses_per_scan));
        if (i == 7 || (i > 7 && arrives(rng))) {  // the first 7 scans lost too: the odometry shows them
          e.on_scan(i * kPeriod);
          ++received;
        }
      }
      INFO(poses_per_scan << " poses per scan: received " << received << ", estimated lost " << e.lost());
      CHECK(e.period_us() == kPeriod);
      CHECK(e.lost() == 300 - received);  // before the first scan, between scans, after the last one
    }
  }
  SECTION("a scan that arrives after its successor was late, not lost") {
    ScanLossEstimator e;
    for (int i = 0; i < 20; ++i) e.on_scan(i * kPeriod);
    e.on_scan(21 * kPeriod);  // 20 is late
    CHECK(e.lost() == 1);
    e.on_late_scan(20 * kPeriod);
    CHECK(e.lost() == 0);
    e.on_late_scan(20 * kPeriod);  // a copy of it changes nothing
    e.on_late_scan(21 * kPeriod);  // nor does a duplicate of the newest
    CHECK(e.lost() == 0);
    CHECK(e.received() == 22);
  }
  SECTION("a clock jump is not a gap") {
    ScanLossEstimator e;
    for (int i = 0; i < 50; ++i) e.on_scan(i * kPeriod);
    e.on_scan(3'600'000'000, true);
    e.on_scan(3'600'000'000 + kPeriod);
    CHECK(e.lost() == 0);
  }
}

TEST_CASE("odometry reset: a jump back to identity continues the trajectory from the last pose") {
  OdometryResetFilter f;
  const Eigen::Isometry3d T_world_start = make_isometry(100.0, 50.0, 0.0, 0.3);
  StampedPose p;
  // 5 m/s along the heading, 10 Hz, for 5 s.
  Eigen::Isometry3d last_out;
  for (int i = 0; i <= 50; ++i) {
    p.utime = i * kPeriod;
    p.T_world_sensor = T_world_start * make_isometry(0.5 * i, 0.0, 0.0, 0.0);
    bool reset = true;
    last_out = f.apply(p, &reset).T_world_sensor;
    CHECK_FALSE(reset);
    CHECK(last_out.isApprox(p.T_world_sensor));
  }
  // The odometry process restarts: it publishes identity, then moves on in its new frame.
  for (int k = 0; k <= 10; ++k) {
    p.utime = (51 + k) * kPeriod;
    p.T_world_sensor = make_isometry(0.5 * k, 0.0, 0.0, 0.0);
    bool reset = false;
    const Eigen::Isometry3d out = f.apply(p, &reset).T_world_sensor;
    CHECK(reset == (k == 0));
    // Zero motion across the reset, then the new frame's motion in the old frame.
    const Eigen::Isometry3d expected = last_out * make_isometry(0.5 * k, 0.0, 0.0, 0.0);
    CHECK((out.translation() - expected.translation()).norm() < 1e-9);
  }
  CHECK(f.resets() == 1);
  // A 2 m/s vehicle that skips 3 s of poses is not a reset.
  p.utime += 3'000'000;
  p.T_world_sensor = make_isometry(5.0 + 6.0, 0.0, 0.0, 0.0);
  bool reset = true;
  f.apply(p, &reset);
  CHECK_FALSE(reset);
}

TEST_CASE("odometry reset: a restart near the old origin (a jump motion could explain) is told by its exact identity pose") {
  OdometryResetFilter f;
  StampedPose p;
  bool reset = true;
  for (int i = 0; i < 6; ++i) {  // 5 m/s towards the origin of its frame, heading 0.2 rad
    p.utime = i * kPeriod;
    p.T_world_sensor = make_isometry(-3.0 + 0.5 * i, 0.1, 0.0, 0.2);
    f.apply(p, &reset);
    CHECK_FALSE(reset);
  }
  p.utime += kPeriod;
  p.T_world_sensor = Eigen::Isometry3d::Identity();  // 0.5 m and 11 deg from the last pose, but exactly identity
  f.apply(p, &reset);
  CHECK(reset);
  p.utime += kPeriod;  // standing still at the new origin is not another reset
  f.apply(p, &reset);
  CHECK_FALSE(reset);
  CHECK(f.resets() == 1);
}

TEST_CASE("sensor layout: a new lidar is one change, odd single scans and slow scene changes are none") {
  SensorLayoutWatch w;
  for (int i = 0; i < 50; ++i) CHECK_FALSE(w.on_scan(28000 + (i % 7) * 300, 16));
  CHECK_FALSE(w.on_scan(9000, 16));                                          // one partial sweep
  for (int i = 0; i < 50; ++i) CHECK_FALSE(w.on_scan(28000 + i * 100, 16));  // the scene opens up slowly
  int confirmed_at = -1;
  for (int i = 0; i < 20; ++i)
    if (w.on_scan(60000 + (i % 5) * 500, 32)) confirmed_at = i;
  CHECK(confirmed_at == 4);
  CHECK(w.changes() == 1);
  CHECK(w.num_rings() == 32);
}
