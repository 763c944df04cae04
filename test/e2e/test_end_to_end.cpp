// End to end: loopd-sim writes a small drive with revisits, the loopd daemon (a separate process) replays it,
// loopd-eval judges what it published against ground truth; the test also reads the published log itself.
#include <catch2/catch.hpp>

#include <filesystem>
#include <set>
#include <map>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/status_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "support/hostile_log.hpp"
#include "support/run_command.hpp"
#include "loopd/base/pose.hpp"
#include "message_convert.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

}  // namespace

TEST_CASE("loopd closes the loops of a simulated VLP-16 drive and corrects its trajectory") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_e2e_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string drive = (dir / "drive.lcmlog").string(), out = (dir / "out.lcmlog").string();
  int rc = 0;
  // The block route: 340 scans = one lap of about 244 m plus a second visit of its first 96 m (cars moved).
  std::string log = loopd::test::run_command(
      kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 340 --seed 11 --route block --quiet", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  log = loopd::test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);

  // What loopd published.
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(out, &error));
  LogEvent ev;
  std::vector<loop_event_t> accepted;
  int rejected = 0;
  trajectory_t last_traj{};
  int revisions = 0;
  std::string final_method;
  status_t status{};
  while (reader.next(&ev)) {
    if (ev.channel == channels::kLoopEvent) {
      loop_event_t e;
      REQUIRE(LogReader::decode(ev, &e));
      if (e.status == loop_event_t::STATUS_ACCEPTED) accepted.push_back(e);
      if (e.status == loop_event_t::STATUS_REJECTED) ++rejected;
    } else if (ev.channel == channels::kTrajectory) {
      const std::int64_t previous = last_traj.revision;
      REQUIRE(LogReader::decode(ev, &last_traj));
      CHECK(last_traj.total_keyframes >= last_traj.num_keyframes);
      if (last_traj.revision == previous && last_traj.full) continue;  // the full snapshot at the end of the replay
      ++revisions;
      CHECK(last_traj.revision == revisions);
      final_method = last_traj.method;
    } else if (ev.channel == channels::kStatus) {
      REQUIRE(LogReader::decode(ev, &status));
    }
  }
  CHECK(accepted.size() >= 10);
  // One revision per accepted loop, and the run's final solve of the whole graph with every keyframe, naming the
  // newest loop.
  CHECK(revisions == static_cast<int>(accepted.size()) + 1);
  CHECK(final_method == "final");
  CHECK(last_traj.loop_event_id == accepted.back().event_id);
  CHECK(status.loops_accepted == static_cast<std::int64_t>(accepted.size()));
  CHECK(status.loops_rejected == rejected);
  REQUIRE(status.num_channels == 2);
  CHECK(status.channels[0].received == 340);
  CHECK(status.channels[0].dropped == 0);
  CHECK(status.channels[0].malformed == 0);
  CHECK(status.shed == 0);
  CHECK(last_traj.full);  // the replay ends with every keyframe
  CHECK(last_traj.num_keyframes == status.keyframes);
  int global = 0;
  for (const auto& e : accepted) {
    CHECK(e.query_utime > e.match_utime);
    // Either the global 4PCS alignment ran, or GICP was guided by the corrected map right after a loop.
    const bool guided = e.reason.find("guided") != std::string::npos;
    CHECK((guided || e.lcp_fraction >= 0.0));
    global += guided ? 0 : 1;
    CHECK(e.icp_residual >= 0.0);
    CHECK(e.stage == "accepted");
  }
  CHECK(global >= 1);  // the first loop of a revisit always comes from the global alignment

  // Every accepted transform agrees with ground truth (loopd-eval: 0.5 m / 2 deg), every revisited stretch is
  // closed, and the corrected trajectory is closer to ground truth than the odometry.
  log = loopd::test::run_command(kBin + "/tools/loopd-eval/loopd-eval --json --drive " + drive + " --results " + out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  const nlohmann::json j = nlohmann::json::parse(loopd::test::last_line(log));
  CHECK(j["closure_precision"].get<double>() == 1.0);
  CHECK(j["closure_recall"].get<double>() >= 0.9);
  CHECK(j["stretches_closed"].get<int>() == j["stretches"].get<int>());
  CHECK(j["mean_error_after"].get<double>() < 0.9 * j["mean_error_before"].get<double>());
  CHECK(j["ate_after"].get<double>() < 0.8 * j["ate_before"].get<double>());
  // A clean drive shows no input trouble: nothing estimated lost, no clock jump, odometry reset or sensor change.
  CHECK(status.scans_lost_estimate == 0);
  CHECK(status.clock_jumps == 0);
  CHECK(status.odometry_resets == 0);
  CHECK(status.sensor_changes == 0);

  // The same drive with the crafted scans that used to stop loopd (fingerprint + random bytes, num_points = -1,
  // num_points = 2^31 - 1) and a damaged event header in the log: all counted, and the rest of the drive gives the
  // same accepted loops.
  const std::string hostile = (dir / "hostile.lcmlog").string(), hostile_out = (dir / "hostile_out.lcmlog").string();
  REQUIRE(loopd::test::copy_with_crafted_scans(drive, hostile, channels::kScan, 200, true) == 3);
  log = loopd::test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + hostile + " --output " + hostile_out, &rc);
  INFO(log);
  REQUIRE(rc == 0);
  CHECK(log.find("could not decode a 4008-byte message") != std::string::npos);  // the first is logged, the rest counted
  CHECK(log.find("1 corrupt event headers") != std::string::npos);
  REQUIRE(reader.open(hostile_out, &error));
  std::set<std::pair<std::int64_t, std::int64_t>> clean_loops, hostile_loops;
  for (const auto& e : accepted) clean_loops.insert({e.query_utime, e.match_utime});
  status_t hostile_status{};
  while (reader.next(&ev)) {
    loop_event_t e;
    if (ev.channel == channels::kLoopEvent && LogReader::decode(ev, &e) && e.status == loop_event_t::STATUS_ACCEPTED)
      hostile_loops.insert({e.query_utime, e.match_utime});
    if (ev.channel == channels::kStatus) REQUIRE(LogReader::decode(ev, &hostile_status));
  }
  CHECK(hostile_loops == clean_loops);
  REQUIRE(hostile_status.num_channels == 2);
  CHECK(hostile_status.channels[0].received == 343);
  CHECK(hostile_status.channels[0].malformed == 3);
  CHECK(hostile_status.channels[0].accepted == status.channels[0].accepted);
  CHECK(hostile_status.keyframes == status.keyframes);
  fs::remove_all(dir);
}
