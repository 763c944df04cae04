// Runs the loopd executable as a separate process.
#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <loopd/status_t.hpp>

#include "lcm_log.hpp"
#include "support/run_command.hpp"
#include "message_convert.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
const std::string kLoopd = std::string(LOOPD_BINARY_DIR) + "/daemon/loopd";

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("loopd_test_" + name + "_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}
}  // namespace

TEST_CASE("loopd --help lists every option and --version prints a version") {
  REQUIRE(fs::exists(kLoopd));
  int rc = 0;
  const std::string help = loopd::test::run_command(kLoopd + " --help", &rc);
  CHECK(rc == 0);
  for (const char* opt : {"--lcm-url", "--config", "--sensor", "--threads", "--replay", "--output", "--print-config", "--version"})
    CHECK(help.find(opt) != std::string::npos);
  CHECK(loopd::test::run_command(kLoopd + " --version", &rc).find("loopd") != std::string::npos);
}

TEST_CASE("loopd refuses a config with a wrong value, naming the field") {
  const fs::path dir = temp_dir("config");
  std::ofstream(dir / "bad.yaml") << "keyframe:\n  min_distance: far\n";
  int rc = 0;
  const std::string out = loopd::test::run_command(kLoopd + " --config " + (dir / "bad.yaml").string(), &rc);
  CHECK(rc != 0);
  CHECK(out.find("keyframe.min_distance") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("SIGTERM stops a live loopd within 1 s") {
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    execl(kLoopd.c_str(), kLoopd.c_str(), "--lcm-url", "memq://", "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // let it start its threads
  const auto t0 = std::chrono::steady_clock::now();
  kill(pid, SIGTERM);
  int status = 0;
  pid_t done = 0;
  while ((done = waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(5))
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (done == 0) kill(pid, SIGKILL), waitpid(pid, &status, 0);
  CHECK(done == pid);
  CHECK(s < 1.0);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("garbage, truncated, NaN, empty, duplicate and orphan input is counted and loopd goes on") {
  const fs::path dir = temp_dir("hostile");
  const std::string in = (dir / "hostile.lcmlog").string(), out = (dir / "out.lcmlog").string();
  {
    LogWriter w;
    std::string error;
    REQUIRE(w.open(in, &error));
    const std::vector<std::uint8_t> garbage(300, 0x5A);
    w.write(channels::kScan, 1, garbage.data(), garbage.size());  // garbage scan
    w.write(channels::kPose, 2, garbage.data(), 7);               // truncated pose
    PointCloud cloud;
    for (int i = 0; i < 2000; ++i) cloud.points.emplace_back(static_cast<float>(i % 50), static_cast<float>(i / 50), 0.f);
    point_cloud_t good = to_message(cloud, 1'000'000, 1, "lidar");
    std::vector<std::uint8_t> buf(static_cast<std::size_t>(good.getEncodedSize()));
    good.encode(buf.data(), 0, static_cast<int>(buf.size()));
    w.write(channels::kScan, 3, buf.data(), buf.size() / 2);  // truncated scan
    PointCloud nan_cloud;
    nan_cloud.points.assign(10, Eigen::Vector3f(NAN, NAN, NAN));
    w.write_message(channels::kScan, 4, to_message(nan_cloud, 900'000, 2, "lidar"));     // all-NaN scan
    w.write_message(channels::kScan, 5, to_message(PointCloud(), 950'000, 3, "lidar"));  // empty scan
    for (int k = 0; k < 5; ++k) {                                                        // poses with no scans, then scans with no poses, duplicates
      StampedPose p;
      p.utime = 2'000'000 + k * 100'000;
      p.T_world_sensor = make_isometry(k * 1.0, 0, 0, 0);
      w.write_message(channels::kPose, p.utime, to_message(p, k));
    }
    StampedPose dup;
    dup.utime = 2'100'000;
    w.write_message(channels::kPose, 2'600'000, to_message(dup, 9));                        // duplicate pose utime
    w.write_message(channels::kScan, 2'200'000, to_message(cloud, 2'200'000, 4, "lidar"));  // ok
    w.write_message(channels::kScan, 2'200'001, to_message(cloud, 2'200'000, 5, "lidar"));  // duplicate scan utime
    w.write_message(channels::kScan, 9'000'000, to_message(cloud, 9'000'000, 6, "lidar"));  // no pose ever
  }
  int rc = 0;
  const std::string log = loopd::test::run_command(kLoopd + " --quiet --replay " + in + " --output " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  LogReader r;
  std::string error;
  REQUIRE(r.open(out, &error));
  LogEvent ev;
  status_t last{};
  bool seen = false;
  while (r.next(&ev))
    if (ev.channel == channels::kStatus && LogReader::decode(ev, &last)) seen = true;
  REQUIRE(seen);
  REQUIRE(last.num_channels == 2);
  const channel_stats_t& scan = last.channels[0];
  const channel_stats_t& pose = last.channels[1];
  CHECK(scan.channel == "LIDAR_SCAN");
  CHECK(scan.received == 7);
  CHECK(scan.malformed == 2);
  CHECK(pose.received == 7);
  CHECK(pose.malformed == 1);
  CHECK(last.invalid_scans == 3);  // all-NaN, empty, duplicate utime
  CHECK(scan.dropped == 1);        // the scan that never got a pose
  CHECK(last.keyframes == 1);      // the one good scan became the first keyframe
  fs::remove_all(dir);
}
