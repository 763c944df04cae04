// Sessions end to end, as a user runs them: loopd-sim drives a town, loopd maps it into a map file, a second drive
// (another day: another start, heading and odometry frame) is replayed on the same map, and loopd-eval judges both
// against ground truth. Same town: the second session is aligned by loops found without a pose prior; another town:
// no loop between the sessions is taken; an odometry reset mid-drive: the new segment is re-anchored.
#include <catch2/catch.hpp>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include "support/run_command.hpp"

namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

std::string run(const std::string& command) {
  int rc = 0;
  const std::string out = loopd::test::run_command(command, &rc);
  INFO(command << "\n" << out);
  REQUIRE(rc == 0);
  return out;
}

void simulate(const fs::path& out, int seed, int session, int scans, const std::string& extra = "") {
  run(kBin + "/tools/loopd-sim/loopd-sim --route block --sensor vlp16 --quiet --seed " + std::to_string(seed) + " --session " +
      std::to_string(session) + " --scans " + std::to_string(scans) + " " + extra + " --out " + out.string());
}

void replay(const fs::path& drive, const fs::path& output, const fs::path& map) {
  run(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive.string() + " --output " + output.string() + " --map " + map.string());
}

nlohmann::json evaluate(const std::string& drives_and_results) {
  return nlohmann::json::parse(loopd::test::last_line(run(kBin + "/tools/loopd-eval/loopd-eval --quiet --json " + drives_and_results)));
}

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) : path(fs::temp_directory_path() / (name + "_" + std::to_string(getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};
}  // namespace

TEST_CASE("a second drive through the same town is aligned to the first one's map, one through another town never is") {
  TempDir dir("loopd_sessions");
  const fs::path& d = dir.path;
  simulate(d / "s1.lcmlog", 3, 1, 800);
  replay(d / "s1.lcmlog", d / "o1.lcmlog", d / "map.db");
  fs::copy_file(d / "map.db", d / "other.db");

  SECTION("same town, driven the other way round from elsewhere (session 2 of the same seed)") {
    simulate(d / "s2.lcmlog", 3, 2, 400);
    replay(d / "s2.lcmlog", d / "o2.lcmlog", d / "map.db");
    const nlohmann::json j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "s2.lcmlog").string() + " --results " +
                                      (d / "o1.lcmlog").string() + " --results " + (d / "o2.lcmlog").string());
    INFO(j.dump(1));
    CHECK(j["sessions"] == 2);
    CHECK(j["sessions_aligned"] == 1);
    CHECK(j["inter_session_loops_accepted"].get<int>() >= 10);
    CHECK(j["inter_session_loops_correct"] == j["inter_session_loops_accepted"]);
    CHECK(j["session_alignment_error_m"].get<double>() < 0.2);
    CHECK(j["session_alignment_error_deg"].get<double>() < 1.0);
    CHECK(j["session_alignment_distance_m"].get<double>() < 30.0);
    CHECK(j["closure_precision"].get<double>() == Approx(1.0));
  }

  SECTION("another town (another seed): no loop between the sessions") {
    simulate(d / "x2.lcmlog", 4, 2, 400);
    replay(d / "x2.lcmlog", d / "ox2.lcmlog", d / "other.db");
    const nlohmann::json j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "x2.lcmlog").string() + " --results " +
                                      (d / "o1.lcmlog").string() + " --results " + (d / "ox2.lcmlog").string());
    INFO(j.dump(1));
    CHECK(j["sessions"] == 2);
    CHECK(j["inter_session_loops_accepted"] == 0);
    CHECK(j["sessions_aligned"] == 0);
  }
}

TEST_CASE("an odometry reset mid-drive opens a new session that loops re-anchor to the map") {
  TempDir dir("loopd_reset");
  const fs::path& d = dir.path;
  simulate(d / "r.lcmlog", 3, 1, 800, "--odometry-reset-at 430");
  replay(d / "r.lcmlog", d / "or.lcmlog", d / "reset.db");
  const nlohmann::json j = evaluate("--drive " + (d / "r.lcmlog").string() + " --results " + (d / "or.lcmlog").string());
  INFO(j.dump(1));
  CHECK(j["sessions"] == 2);
  CHECK(j["sessions_aligned"] == 1);
  CHECK(j["inter_session_loops_correct"] == j["inter_session_loops_accepted"]);
  CHECK(j["session_alignment_error_m"].get<double>() < 0.2);
  CHECK(j["session_alignment_error_deg"].get<double>() < 1.0);
  CHECK(j["session_alignment_distance_m"].get<double>() < 30.0);
  // Against the same drive without the reset: the corrected trajectory is no worse than 1.2x (README "Sessions").
  simulate(d / "n.lcmlog", 3, 1, 800);
  replay(d / "n.lcmlog", d / "on.lcmlog", d / "plain.db");
  const nlohmann::json plain = evaluate("--drive " + (d / "n.lcmlog").string() + " --results " + (d / "on.lcmlog").string());
  CHECK(j["ate_after"].get<double>() <= 1.2 * plain["ate_after"].get<double>() + 0.05);
}
