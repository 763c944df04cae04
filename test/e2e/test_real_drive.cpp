// The shared real recording end to end, as a new user would run it: a handheld / small-site drive of an OS0-64-like
// lidar (360 x 90 deg, 177 scans, 74 m in an 18 x 20 m area; ../shared/data/real/balm), converted with injected
// odometry drift, replayed by loopd with no --sensor and no config. Its revisits are closed with the right transforms
// and no wrong loop; split in two, its second half localizes in its first half's map. Skips when the recording is absent.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "support/data_dir.hpp"
#include "support/run_command.hpp"

namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;
}  // namespace

TEST_CASE("a real handheld drive: loopd with no sensor flag and no config closes its revisits, every loop right", "[real]") {
  LOOPD_REQUIRE_DATA(poses, "real/balm/poses.txt");
  const std::string seq = fs::path(poses).parent_path().string();
  const fs::path dir = fs::temp_directory_path() / ("loopd_real_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string drive = (dir / "balm.lcmlog").string(), out = (dir / "out.lcmlog").string();
  int rc = 0;
  std::string log =
      loopd::test::run_command(kBin + "/tools/kitti2lcm/kitti2lcm --quiet --sequence " + seq + " --poses " + seq + "/poses.txt --times " + seq +
                                   "/times.txt --calib " + seq + "/calib_identity.txt --heading-bias 0.05 --scale-bias 0.02 --out " + drive,
                               &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(kBin + "/daemon/loopd --replay " + drive + " --output " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  // The sensor is read from the scans: a wide vertical fan (about +-45 deg), logged once.
  CHECK(log.find("loopd: sensor (auto): ") != std::string::npos);
  // Loops within 0.2 m / 2 deg of the recording's own odometry count as correct; revisits as the issue counts them.
  const std::string eval = loopd::test::run_command(kBin + "/tools/loopd-eval/loopd-eval --json --quiet --loop-distance 5 --min-frame-gap 30 " +
                                                        "--closure-translation 0.2 --closure-rotation 2 --drive " + drive + " --results " + out,
                                                    &rc);
  INFO(eval);
  REQUIRE(rc == 0);
  const nlohmann::json j = nlohmann::json::parse(loopd::test::last_line(eval));
  const int accepted = j["accepted"].get<int>(), correct = j["correct"].get<int>();
  CHECK(accepted >= 5);
  CHECK(correct == accepted);
  CHECK(j["stretches_closed"].get<int>() >= 2);
  CHECK(j["loop_translation_error_max"].get<double>() < 0.2);
  CHECK(j["loop_rotation_error_max_deg"].get<double>() < 2.0);
  CHECK(j["ate_after"].get<double>() <= j["ate_before"].get<double>());
  fs::remove_all(dir);
}

namespace {
std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
}  // namespace

TEST_CASE("the real handheld drive split in two: its first half's map, the second half localized in it a day later", "[real]") {
  LOOPD_REQUIRE_DATA(poses, "real/balm/poses.txt");
  const std::string seq = fs::path(poses).parent_path().string();
  const fs::path dir = fs::temp_directory_path() / ("loopd_real_split_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string first = (dir / "first.lcmlog").string(), second = (dir / "second.lcmlog").string(), map = (dir / "map.db").string();
  const std::string convert = kBin + "/tools/kitti2lcm/kitti2lcm --quiet --sequence " + seq + " --poses " + seq + "/poses.txt --times " + seq +
                              "/times.txt --calib " + seq + "/calib_identity.txt --heading-bias 0.05 --scale-bias 0.02 ";
  int rc = 0;
  std::string log = loopd::test::run_command(convert + "--max-frames 89 --out " + first, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  // Its own odometry (another drift seed), a day later: a second drive, not a restart of the first.
  log = loopd::test::run_command(convert + "--first-frame 89 --drift-seed 2 --utime-offset 86401000000 --out " + second, &rc);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(kBin + "/daemon/loopd --replay " + first + " --output " + (dir / "o1.lcmlog").string() + " --map " + map, &rc);
  REQUIRE(rc == 0);
  const std::string before = file_bytes(map);
  log = loopd::test::run_command(kBin + "/daemon/loopd --localize --replay " + second + " --output " + (dir / "o2.lcmlog").string() + " --map " + map,
                                 &rc);
  INFO(log);
  REQUIRE(rc == 0);
  CHECK(log.find("session 1 opened") != std::string::npos);
  const std::string eval = loopd::test::run_command(kBin + "/tools/loopd-eval/loopd-eval --json --quiet --drive " + first + " --drive " + second +
                                                        " --results " + (dir / "o1.lcmlog").string() + " --results " + (dir / "o2.lcmlog").string(),
                                                    &rc);
  INFO(eval);
  REQUIRE(rc == 0);
  const nlohmann::json j = nlohmann::json::parse(loopd::test::last_line(eval));
  // Measured: aligned after 0.9 m, 19 of 19 loops to the map right, 0.107 m / 0.35 deg from ground truth.
  CHECK(j["sessions_aligned"] == 1);
  CHECK(j["inter_session_loops_accepted"].get<int>() >= 5);
  CHECK(j["inter_session_loops_correct"] == j["inter_session_loops_accepted"]);
  CHECK(j["session_alignment_error_m"].get<double>() < 0.2);
  CHECK(j["session_alignment_error_deg"].get<double>() < 1.0);
  CHECK(file_bytes(map) == before);  // localizing never changes the map
  fs::remove_all(dir);
}
