// The systemd watchdog's notion of progress: ProgressWatch on explicit times, PipelineWatchdog sending WATCHDOG=1 to a
// notify socket this test owns, and LoopdEngine::progress() while a real engine's sequential stage is held.
#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <random>
#include <string>
#include <sys/socket.h>
#include <sys/un.h>
#include <thread>
#include <unistd.h>

#include "loopd/runtime/loopd_engine.hpp"
#include "systemd_notify.hpp"
#include "watchdog.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

/// A Unix datagram socket in a temp dir, as systemd's NOTIFY_SOCKET; closed and removed at the end.
class NotifySocket {
 public:
  NotifySocket() {
    dir_ = fs::temp_directory_path() / ("loopd_watchdog_" + std::to_string(getpid()));
    fs::create_directories(dir_);
    path_ = (dir_ / "notify.sock").string();
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path_.copy(addr.sun_path, sizeof(addr.sun_path) - 1);
    bound_ = fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0;
  }
  ~NotifySocket() {
    if (fd_ >= 0) close(fd_);
    fs::remove_all(dir_);
  }
  bool bound() const { return bound_; }
  const std::string& path() const { return path_; }
  /// Reads every datagram waiting now into the list (a Unix datagram queue holds few: read after each send).
  void read() {
    char buf[4096];
    for (;;) {
      const ssize_t n = recv(fd_, buf, sizeof(buf), 0);
      if (n < 0) break;
      got_.emplace_back(buf, static_cast<std::size_t>(n));
    }
  }
  /// Everything received since the last call.
  std::vector<std::string> drain() {
    read();
    std::vector<std::string> out;
    out.swap(got_);
    return out;
  }

 private:
  fs::path dir_;
  std::string path_;
  int fd_ = -1;
  bool bound_ = false;
  std::vector<std::string> got_;
};

/// Sets environment variables for the life of the object (the notifier reads them when constructed).
struct ScopedEnv {
  ScopedEnv(const std::string& socket, const std::string& watchdog_usec) {
    setenv("NOTIFY_SOCKET", socket.c_str(), 1);
    setenv("WATCHDOG_USEC", watchdog_usec.c_str(), 1);
    unsetenv("WATCHDOG_PID");
  }
  ~ScopedEnv() {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
  }
};

int count(const std::vector<std::string>& messages, const std::string& text) {
  int n = 0;
  for (const auto& m : messages) n += m == text ? 1 : 0;
  return n;
}

/// Holds the sequential stage inside on_keyframe until released, as a hung verification or map write would.
class HoldingSink : public EngineSink {
 public:
  void on_keyframe(const KeyframeRecord&, const Eigen::Isometry3d&, const MapCloudBlob&) override {
    std::unique_lock<std::mutex> lock(mutex_);
    ++entered_;
    cv_.notify_all();
    cv_.wait(lock, [&] { return released_; });
  }
  void on_decision(const LoopDecision&) override {}
  void on_correction(const CorrectionOutput&) override {}
  bool wait_entered(int n) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::seconds(60), [&] { return entered_ >= n; });
  }
  void release() {
    std::lock_guard<std::mutex> lock(mutex_);
    released_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  int entered_ = 0;
  bool released_ = false;
};

PointCloud box_scan(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  PointCloud c;
  for (int i = 0; i < 4000; ++i) {
    const float a = u(rng), b = u(rng);
    if (i % 3 == 0)
      c.points.emplace_back(10.f * a, 10.f * b, -1.8f);
    else if (i % 3 == 1)
      c.points.emplace_back(10.f, 10.f * a, 2.f * b);
    else
      c.points.emplace_back(3.f + a, 2.f + b, 0.5f * u(rng) - 1.f);
  }
  return c;
}

}  // namespace

TEST_CASE("ProgressWatch: idle is alive however long, pending work without progress is a stall after stall_s") {
  ProgressWatch w(2.0);
  // Idle (nothing pending): a parked vehicle sends nothing for an hour and is alive.
  CHECK(w.update({0, false}, 0.0));
  CHECK(w.update({0, false}, 3600.0));
  // Work waits and the counter moves every second: alive.
  for (int i = 1; i <= 5; ++i) CHECK(w.update({i, true}, 3600.0 + i));
  // The counter stops with work waiting: alive up to 2 s, a stall beyond.
  CHECK(w.update({5, true}, 3606.9));
  CHECK(w.update({5, true}, 3607.0));
  CHECK_FALSE(w.update({5, true}, 3607.1));
  CHECK(w.stalled_for(3607.1) == Approx(2.1));
  CHECK_FALSE(w.update({5, true}, 3700.0));
  // It moves again: alive at once.
  CHECK(w.update({6, true}, 3700.1));
  // The work drained while the counter stood still: alive (nothing waits).
  CHECK(w.update({6, false}, 3800.0));
}

TEST_CASE("PipelineWatchdog pings the notify socket at half WATCHDOG_USEC, never while a stage is stalled, and again after") {
  NotifySocket sock;
  REQUIRE(sock.bound());
  ScopedEnv env(sock.path(), "1000000");
  SystemdNotifier notifier;
  REQUIRE(notifier.enabled());
  CHECK(notifier.watchdog_usec() == 1000000u);
  CHECK(notifier.ping_interval_s() == Approx(0.5));
  PipelineWatchdog watchdog(notifier, 2.0);
  // 10 s of polls every 0.1 s with the stage busy and moving: one ping per 0.5 s.
  std::int64_t steps = 0;
  for (int i = 0; i < 100; ++i) {
    CHECK(watchdog.poll({{"sequential stage", {++steps, true}}}, i * 0.1));
    sock.read();
  }
  const int moving = count(sock.drain(), "WATCHDOG=1");
  CHECK(moving >= 19);
  CHECK(moving <= 21);
  // The counter stops with work waiting: pings for 2 s more, then none for the 8 s that follow.
  int alive_polls = 0;
  for (int i = 100; i < 200; ++i) {
    alive_polls += watchdog.poll({{"sequential stage", {steps, true}}}, i * 0.1) ? 1 : 0;
    sock.read();
  }
  CHECK(alive_polls >= 20);
  CHECK(alive_polls <= 22);
  const int during_stall = count(sock.drain(), "WATCHDOG=1");
  CHECK(during_stall >= 4);
  CHECK(during_stall <= 5);
  for (int i = 200; i < 260; ++i) CHECK_FALSE(watchdog.poll({{"sequential stage", {steps, true}}}, i * 0.1));
  CHECK(count(sock.drain(), "WATCHDOG=1") == 0);
  // Progress again: pings resume on the next poll.
  CHECK(watchdog.poll({{"sequential stage", {steps + 1, true}}}, 26.0));
  CHECK(count(sock.drain(), "WATCHDOG=1") == 1);
  CHECK(watchdog.pings() == moving + during_stall + 1);
}

TEST_CASE("SystemdNotifier sends READY, STATUS and STOPPING as sd_notify lines and nothing without NOTIFY_SOCKET") {
  NotifySocket sock;
  REQUIRE(sock.bound());
  {
    ScopedEnv env(sock.path(), "0");
    SystemdNotifier notifier;
    CHECK(notifier.watchdog_usec() == 0u);  // WATCHDOG_USEC=0: no watchdog, watchdog() sends nothing
    notifier.ready("keyframes 0\nsecond line");
    notifier.status("keyframes 3");
    notifier.watchdog();
    notifier.stopping("done");
    const std::vector<std::string> got = sock.drain();
    REQUIRE(got.size() == 3);
    CHECK(got[0] == "READY=1\nSTATUS=keyframes 0 second line");  // STATUS= stays one line
    CHECK(got[1] == "STATUS=keyframes 3");
    CHECK(got[2] == "STOPPING=1\nSTATUS=done");
  }
  SystemdNotifier outside;  // NOTIFY_SOCKET unset: loopd started by hand
  CHECK_FALSE(outside.enabled());
  outside.ready("x");
  outside.watchdog();
  CHECK(sock.drain().empty());
}

TEST_CASE("LoopdEngine::progress: a held sequential stage shows pending work and a counter that stands still") {
  HoldingSink sink;
  EngineConfig config;
  config.detector.sensor = "vlp16";
  config.detector.m2dp.backend = Backend::kCpu;
  config.num_threads = 2;
  config.block_when_full = true;
  LoopdEngine engine(config, &sink);
  const EngineProgress idle = engine.progress();
  CHECK_FALSE(idle.workers.pending);
  CHECK_FALSE(idle.sequential.pending);
  for (int i = 0; i < 6; ++i) {
    const std::int64_t t = 1'000'000 + i * 100'000;
    StampedPose p;
    p.utime = t;
    p.T_world_sensor = make_isometry(3.0 * i, 0, 0, 0);  // 3 m apart: every scan is a keyframe
    engine.push_pose(p, 0.0);
    REQUIRE(engine.push_scan(t, box_scan(static_cast<std::uint32_t>(i)), 0.0));
  }
  engine.tick(10.0);
  REQUIRE(sink.wait_entered(1));
  // The workers finish the other keyframes; the sequential stage stays inside keyframe 0.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const EngineProgress held = engine.progress();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const EngineProgress still = engine.progress();
  CHECK(held.sequential.pending);
  CHECK(still.sequential.pending);
  CHECK(still.sequential.steps == held.sequential.steps);
  CHECK(held.sequential.steps == 0);
  ProgressWatch watch(0.2);
  CHECK(watch.update(held.sequential, 0.0));
  CHECK_FALSE(watch.update(still.sequential, 0.3));
  sink.release();
  engine.finish();
  // finish() returns once every keyframe is sequenced; the worker that sequenced the last one leaves a moment later.
  EngineProgress done = engine.progress();
  for (int i = 0; i < 500 && done.workers.pending; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    done = engine.progress();
  }
  CHECK_FALSE(done.workers.pending);
  CHECK_FALSE(done.sequential.pending);
  CHECK(done.workers.steps >= 5);                            // features of the keyframes (a scan may still be the selector's)
  CHECK(done.sequential.steps >= engine.stats().keyframes);  // a step per keyframe sequenced (+ one per decision)
  CHECK(engine.stats().keyframes >= 5);
}
