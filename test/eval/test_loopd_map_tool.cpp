// loopd-map on a real map: a simulated VLP-16 drive replayed by loopd --map --output; the tool's counts, trajectory
// and loop list are checked against what loopd published (its output log) and printed; `check` passes on the map,
// fails (exit 1) on a copy with a loop naming a missing keyframe; missing, garbage, foreign and future-schema files
// are refused with exit 2 and no file is created.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <regex>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "message_convert.hpp"
#include "support/run_command.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

const std::string kBin = LOOPD_BINARY_DIR;
const std::string kMapTool = kBin + "/tools/loopd-map/loopd-map";

/// A map and the output log of one replay, made once per process and removed at its end.
struct ReplayedMap {
  fs::path dir = fs::temp_directory_path() / ("loopd_test_map_tool_" + std::to_string(::getpid()));
  std::string map = (dir / "drive.map").string(), out = (dir / "out.lcmlog").string();
  std::string loopd_log;  ///< what loopd printed

  ReplayedMap() {
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string drive = (dir / "drive.lcmlog").string();
    int rc = 0;
    std::string log =
        test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 340 --seed 23 --route block --quiet", &rc);
    INFO(log);
    REQUIRE(rc == 0);
    loopd_log = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --replay " + drive + " --map " + map + " --output " + out, &rc);
    INFO(loopd_log);
    REQUIRE(rc == 0);
    fs::remove(drive);  // 150 MB; the map and the output are what is checked
  }
  ~ReplayedMap() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  ReplayedMap(const ReplayedMap&) = delete;
  ReplayedMap& operator=(const ReplayedMap&) = delete;
};

const ReplayedMap& replayed() {
  static const ReplayedMap replay;
  return replay;
}

/// What loopd published: its loop events and its last corrected trajectory.
struct Published {
  std::vector<loop_event_t> events;
  trajectory_t last_trajectory;
  int trajectories = 0;
};

Published read_published(const std::string& path) {
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(path, &error));
  Published p;
  LogEvent ev;
  loop_event_t e;
  trajectory_t t;
  while (reader.next(&ev)) {
    if (ev.channel == channels::kLoopEvent && LogReader::decode(ev, &e)) p.events.push_back(e);
    if (ev.channel == channels::kTrajectory && LogReader::decode(ev, &t)) {
      p.last_trajectory = t;
      ++p.trajectories;
    }
  }
  return p;
}

/// Runs loopd-map; its exit status in `rc`, its whole output returned.
std::string map_tool(const std::string& args, int* rc) { return test::run_command(kMapTool + " " + args, rc); }

/// Runs loopd-map with --json; its last line parsed.
nlohmann::json map_json(const std::string& args, int* rc) {
  const std::string log = map_tool("--quiet --json " + args, rc);
  INFO(log);
  const auto j = nlohmann::json::parse(test::last_line(log), nullptr, false);
  REQUIRE_FALSE(j.is_discarded());
  return j;
}

/// A count loopd printed at the end of the replay ("keyframes 157, loops accepted 57, rejected 9").
std::int64_t printed_count(const std::string& log, const std::string& name) {
  std::smatch m;
  REQUIRE(std::regex_search(log, m, std::regex("replay finished.*[ ,]" + name + " ([0-9]+)")));
  return std::stoll(m[1]);
}

/// Runs sqlite3 on a file; false when the sqlite3 command-line shell is not installed.
bool sqlite3(const std::string& file, const std::string& sql) {
  int rc = 0;
  if (test::run_command("command -v sqlite3", &rc), rc != 0) return false;
  const std::string log = test::run_command("sqlite3 " + file + " \"" + sql + "\"", &rc);
  INFO(log);
  REQUIRE(rc == 0);
  return true;
}

/// The first accepted loop made to name a keyframe the map does not hold.
const char* const kLoopToMissingKeyframe = "UPDATE loops SET match_idx = 99999 WHERE event_id = (SELECT min(event_id) FROM loops WHERE status = 1)";

/// A copy of the replayed map named `name`, altered by `sql`; empty (with a warning) when the sqlite3 shell is not
/// installed.
std::string altered_copy(const ReplayedMap& r, const std::string& name, const std::string& sql) {
  const std::string copy = (r.dir / name).string();
  fs::copy_file(r.map, copy, fs::copy_options::overwrite_existing);
  if (!sqlite3(copy, sql)) {
    WARN("sqlite3 shell not installed: the altered map is skipped");
    return {};
  }
  return copy;
}

}  // namespace

TEST_CASE("loopd-map info, trajectory and loops hold what loopd printed and published") {
  const ReplayedMap& r = replayed();
  const Published pub = read_published(r.out);
  std::int64_t accepted = 0, rejected = 0;
  for (const loop_event_t& e : pub.events) {
    accepted += e.status == loop_event_t::STATUS_ACCEPTED ? 1 : 0;
    rejected += e.status == loop_event_t::STATUS_REJECTED ? 1 : 0;
  }
  REQUIRE(pub.trajectories > 0);
  REQUIRE(accepted >= 5);  // the block route's second visit closes loops
  int rc = -1;

  SECTION("info: keyframes, accepted and rejected loops as loopd printed and published; bytes on disk") {
    const auto j = map_json(r.map + " info", &rc);
    CHECK(rc == 0);
    CHECK(j["sessions"] == 1);
    CHECK(j["keyframes"] == printed_count(r.loopd_log, "keyframes"));
    CHECK(j["keyframes"] == pub.last_trajectory.num_keyframes);
    CHECK(j["loops_accepted"] == printed_count(r.loopd_log, "loops accepted"));
    CHECK(j["loops_accepted"] == accepted);
    CHECK(j["loops_rejected"] == printed_count(r.loopd_log, "rejected"));
    CHECK(j["loops_rejected"] == rejected);
    CHECK(j["correction_revision"] == pub.last_trajectory.revision);
    CHECK(pub.last_trajectory.method == "final");  // the end-of-run solve is published and stored with --map too
    CHECK(j["keyframes_with_features"].get<std::int64_t>() > 0);
    CHECK(j["keyframes_with_features"].get<std::int64_t>() <= j["keyframes"].get<std::int64_t>());
    CHECK(j["bytes"].get<std::int64_t>() >= static_cast<std::int64_t>(fs::file_size(r.map)));
    CHECK(j["session_list"][0]["sensor"] == "vlp16");
  }

  SECTION("trajectory: one KITTI line per keyframe, the corrected poses loopd published last; --odometry differs") {
    const std::string kitti = (r.dir / "corrected.kitti").string(), odom = (r.dir / "odometry.kitti").string();
    const std::string tum = (r.dir / "corrected.tum").string();
    auto j = map_json(r.map + " trajectory --format kitti --out " + kitti, &rc);
    CHECK(rc == 0);
    j = map_json(r.map + " trajectory --format kitti --odometry --out " + odom, &rc);
    CHECK(rc == 0);
    CHECK(j["kind"] == "odometry");
    j = map_json(r.map + " trajectory --format tum --out " + tum, &rc);
    CHECK(rc == 0);
    const TrajectoryFile corrected = read_trajectory(kitti, TrajectoryFormat::kKitti);
    const TrajectoryFile odometry = read_trajectory(odom, TrajectoryFormat::kKitti);
    const TrajectoryFile stamped = read_trajectory(tum, TrajectoryFormat::kTum);
    REQUIRE(corrected.ok);
    REQUIRE(odometry.ok);
    REQUIRE(stamped.ok);
    const trajectory_t& t = pub.last_trajectory;
    REQUIRE(corrected.poses.size() == static_cast<std::size_t>(t.num_keyframes));
    REQUIRE(odometry.poses.size() == corrected.poses.size());
    REQUIRE(stamped.poses.size() == corrected.poses.size());
    double max_diff = 0.0, max_rot = 0.0, max_odometry_diff = 0.0;
    for (std::size_t i = 0; i < corrected.poses.size(); ++i) {
      const keyframe_pose_t& k = t.keyframes[i];
      const Eigen::Vector3d published(k.position[0], k.position[1], k.position[2]);
      const Eigen::Vector3d written = corrected.poses[i].translation();
      // The writer prints 9 significant digits: equal to within half a unit in the 9th digit (1e-9 m near the origin).
      for (int a = 0; a < 3; ++a) CHECK(std::abs(written[a] - published[a]) <= 1e-9 + 5e-9 * std::abs(published[a]));
      max_diff = std::max(max_diff, (written - published).norm());
      const Eigen::Quaterniond q(k.orientation[0], k.orientation[1], k.orientation[2], k.orientation[3]);
      max_rot = std::max(max_rot, Eigen::AngleAxisd(q.toRotationMatrix().transpose() * corrected.poses[i].linear()).angle());
      max_odometry_diff = std::max(max_odometry_diff, (odometry.poses[i].translation() - published).norm());
      CHECK(stamped.stamps[i] == Approx(static_cast<double>(k.utime) * 1e-6).margin(1e-6));
      CHECK((stamped.poses[i].translation() - written).norm() < 1e-6);
    }
    CHECK(max_diff < 1e-6);
    CHECK(max_rot < 1e-7);
    CHECK(max_odometry_diff > 0.05);  // loop corrections moved the keyframes away from odometry
  }

  SECTION("keyframes after the stored correction: T_map_odom * T_odom_sensor, the last one where loopd published it") {
    // A copy whose correction covers only the first 100 keyframes (keys 12 bytes, poses 96 bytes each), T_map_odom
    // kept: the later keyframes are mapped with it, and the last keyframe's corrected pose is T_map_odom's anchor.
    const std::string copy = (r.dir / "short_correction.map").string(), kitti = (r.dir / "short.kitti").string();
    fs::copy_file(r.map, copy, fs::copy_options::overwrite_existing);
    if (!sqlite3(copy, "UPDATE correction SET keys = substr(keys, 1, 1200), poses = substr(poses, 1, 9600)")) {
      WARN("sqlite3 shell not installed: skipped");
      return;
    }
    const auto j = map_json(copy + " trajectory --format kitti --out " + kitti, &rc);
    CHECK(rc == 0);
    CHECK(j["from_correction"] == 100);
    CHECK(j["after_correction"] == pub.last_trajectory.num_keyframes - 100);
    const TrajectoryFile corrected = read_trajectory(kitti, TrajectoryFormat::kKitti);
    REQUIRE(corrected.ok);
    REQUIRE(corrected.poses.size() == static_cast<std::size_t>(pub.last_trajectory.num_keyframes));
    const keyframe_pose_t& last = pub.last_trajectory.keyframes.back();
    const Eigen::Vector3d published(last.position[0], last.position[1], last.position[2]);
    CHECK((corrected.poses.back().translation() - published).norm() < 1e-6);
  }

  SECTION("loops: the accepted events by default, every decision with --all, in event order") {
    auto j = map_json(r.map + " loops", &rc);
    CHECK(rc == 0);
    CHECK(j["accepted"] == accepted);
    REQUIRE(j["loops"].size() == static_cast<std::size_t>(accepted));
    std::size_t n = 0;
    for (const loop_event_t& e : pub.events) {
      if (e.status != loop_event_t::STATUS_ACCEPTED) continue;
      CHECK(j["loops"][n]["event_id"] == e.event_id);
      CHECK(j["loops"][n]["query"] == "0/" + std::to_string(e.query_id));
      CHECK(j["loops"][n]["match"] == "0/" + std::to_string(e.match_id));
      ++n;
    }
    j = map_json(r.map + " loops --all", &rc);
    CHECK(rc == 0);
    CHECK(j["rejected"] == rejected);
    CHECK(j["loops"].size() == static_cast<std::size_t>(accepted + rejected));
    const std::string table = map_tool(r.map + " loops", &rc);
    CHECK(table.find("T_match_query") != std::string::npos);
    CHECK(table.find(std::to_string(accepted) + " accepted") != std::string::npos);
  }
}

TEST_CASE("loopd-map loops --suspect: accepted loops by their residual after the correction, a wrong loop first") {
  const ReplayedMap& r = replayed();
  int rc = -1;
  const nlohmann::json all = map_json(r.map + " loops", &rc);
  auto j = map_json(r.map + " loops --suspect --limit 100000", &rc);
  CHECK(rc == 0);
  CHECK(j["suspect"] == true);
  CHECK(j["correction_revision"].get<std::int64_t>() > 0);
  CHECK(j["without_pose"] == 0);
  REQUIRE(j["accepted"] == all["accepted"]);
  REQUIRE(j["loops"].size() == all["loops"].size());
  double largest = 0.0;
  for (std::size_t i = 0; i < j["loops"].size(); ++i) {
    const double residual = j["loops"][i]["residual_m"].get<double>();
    if (i > 0) CHECK(residual <= j["loops"][i - 1]["residual_m"].get<double>());  // largest first
    largest = std::max(largest, residual);
  }
  INFO("largest residual of the run's own loops " << largest << " m");
  CHECK(largest < 1.0);  // the correction agrees with the loops it was solved with

  SECTION("a wrong loop injected into the store (a real loop's transform to a keyframe 60 keyframes earlier) leads the list") {
    const std::string copy =
        altered_copy(r, "suspect.map",
                     "INSERT INTO loops SELECT (SELECT max(event_id) + 1 FROM loops), query_session, query_idx, match_session, "
                     "query_idx - 60, query_utime, match_utime, status, stage, reason, gate_distance, gate_radius, descriptor_distance, "
                     "lcp_fraction, icp_residual, icp_fitness, hungarian_consistency, degeneracy, T_match_query, information, retrieval, "
                     "place_distance, confirmed, published FROM loops WHERE status = 1 AND query_idx >= 60 ORDER BY event_id LIMIT 1");
    if (copy.empty()) return;
    j = map_json(copy + " loops --suspect --limit 2", &rc);
    CHECK(rc == 0);
    REQUIRE(j["loops"].size() == 2);
    CHECK(j["accepted"] == all["accepted"].get<std::int64_t>() + 1);
    CHECK(j["loops"][0]["event_id"].get<std::int64_t>() > all["loops"].back()["event_id"].get<std::int64_t>());  // the injected one
    CHECK(j["loops"][0]["residual_m"].get<double>() > 5.0);
    CHECK(j["loops"][1]["residual_m"].get<double>() == Approx(largest));
  }

  SECTION("a loop naming a keyframe the map does not hold is counted, not listed") {
    const std::string copy = altered_copy(r, "suspect_missing.map", kLoopToMissingKeyframe);
    if (copy.empty()) return;
    j = map_json(copy + " loops --suspect --limit 100000", &rc);
    CHECK(rc == 0);
    CHECK(j["without_pose"] == 1);
    CHECK(j["accepted"] == all["accepted"]);
    CHECK(j["loops"].size() + 1 == all["loops"].size());
  }

  SECTION("--suspect with --all is refused") {
    map_tool(r.map + " loops --suspect --all", &rc);
    CHECK(rc == 2);
  }
}

namespace {

/// The first accepted loop 60 or more keyframes long made to name a keyframe 60 keyframes before its match, confirmed
/// (no robust kernel): a wrong loop as a place that looks like another would make it.
const char* const kWrongConfirmedLoop =
    "UPDATE loops SET match_idx = match_idx - 60, confirmed = 1 WHERE event_id = (SELECT min(event_id) FROM loops WHERE status = 1 AND "
    "match_idx >= 60)";

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("loopd-map loops --revoke, ledger and correct: a revoked wrong loop leaves no trace, a restored one comes back") {
  const ReplayedMap& r = replayed();
  const std::string wrong = altered_copy(r, "revoke_wrong.map", kWrongConfirmedLoop);
  if (wrong.empty()) return;
  const std::string right = (r.dir / "revoke_right.map").string();
  fs::copy_file(r.map, right, fs::copy_options::overwrite_existing);
  int rc = -1;
  // The loop made wrong: the one whose match differs from the map loopd made.
  const nlohmann::json original = map_json(r.map + " loops --all", &rc), altered = map_json(wrong + " loops --all", &rc);
  REQUIRE(original["loops"].size() == altered["loops"].size());
  std::int64_t event = -1, rejected = -1;
  for (std::size_t i = 0; i < original["loops"].size(); ++i) {
    if (original["loops"][i]["match"] != altered["loops"][i]["match"]) event = original["loops"][i]["event_id"].get<std::int64_t>();
    if (original["loops"][i]["status"] == "rejected") rejected = original["loops"][i]["event_id"].get<std::int64_t>();
  }
  REQUIRE(event >= 0);
  REQUIRE(rejected >= 0);
  const std::int64_t accepted = original["accepted"].get<std::int64_t>();

  nlohmann::json j = map_json(wrong + " correct", &rc);
  REQUIRE(rc == 0);
  CHECK(j["loops"] == accepted);
  CHECK(j["moved_max_m"].get<double>() > 10.0);  // the wrong loop wrecks the map (59 m measured)
  const std::string with_wrong_loop = (r.dir / "with_wrong.kitti").string();
  map_tool(wrong + " trajectory --format kitti --out " + with_wrong_loop, &rc);
  REQUIRE(rc == 0);

  j = map_json(wrong + " loops --revoke " + std::to_string(event) + " --reason 'doubled wall, east side' --who tester", &rc);
  REQUIRE(rc == 0);
  CHECK(j["seq"] == 1);
  CHECK(j["action"] == "revoke");
  CHECK(j["who"] == "tester");
  CHECK(j["reason"] == "doubled wall, east side");
  j = map_json(wrong + " info", &rc);
  CHECK(j["loops_revoked"] == 1);
  CHECK(j["ledger_seq"] == 1);
  CHECK(j["correction_ledger_seq"] == 0);  // the correction is older than the ledger until correct runs

  std::string log = map_tool(wrong + " loops --revoke " + std::to_string(event), &rc);
  CHECK(rc == 2);
  CHECK(log.find("revoked already") != std::string::npos);
  log = map_tool(wrong + " loops --restore " + std::to_string(event + 1), &rc);
  CHECK(rc == 2);
  CHECK(log.find("not revoked") != std::string::npos);
  log = map_tool(wrong + " loops --revoke " + std::to_string(rejected), &rc);
  CHECK(rc == 2);
  CHECK(log.find("not accepted") != std::string::npos);
  map_tool(wrong + " loops --reason alone", &rc);
  CHECK(rc == 2);

  j = map_json(wrong + " correct", &rc);
  REQUIRE(rc == 0);
  CHECK(j["loops"] == accepted - 1);
  CHECK(j["loops_revoked"] == 1);
  CHECK(j["ledger_seq"] == 1);
  // The map loopd made, with the same (right) loop revoked, corrects to the same trajectory to the last digit.
  map_json(right + " loops --revoke " + std::to_string(event), &rc);
  REQUIRE(rc == 0);
  map_json(right + " correct", &rc);
  REQUIRE(rc == 0);
  const std::string revoked_wrong = (r.dir / "revoked_wrong.kitti").string(), revoked_right = (r.dir / "revoked_right.kitti").string();
  map_tool(wrong + " trajectory --format kitti --out " + revoked_wrong, &rc);
  map_tool(right + " trajectory --format kitti --out " + revoked_right, &rc);
  CHECK(file_text(revoked_wrong) == file_text(revoked_right));
  CHECK(file_text(revoked_wrong) != file_text(with_wrong_loop));

  j = map_json(wrong + " ledger", &rc);
  CHECK(rc == 0);
  REQUIRE(j["entries"].size() == 1);
  CHECK(j["entries"][0]["event_id"] == event);
  CHECK(j["revoked"] == nlohmann::json::array({event}));
  CHECK(j["correction_ledger_seq"] == 1);
  j = map_json(wrong + " loops", &rc);
  for (const auto& loop : j["loops"]) CHECK(loop["revoked"] == (loop["event_id"] == event));
  CHECK(j["revoked"] == 1);
  j = map_json(wrong + " loops --suspect --limit 1000", &rc);
  CHECK(j["revoked"] == 1);
  CHECK(j["loops"].size() == static_cast<std::size_t>(accepted - 1));
  map_json(wrong + " check", &rc);
  CHECK(rc == 0);

  SECTION("restored, the loop is back: the trajectory with the wrong loop again") {
    j = map_json(wrong + " loops --restore " + std::to_string(event) + " --reason 'it was right after all'", &rc);
    REQUIRE(rc == 0);
    CHECK(j["seq"] == 2);
    j = map_json(wrong + " correct", &rc);
    CHECK(j["loops"] == accepted);
    const std::string restored = (r.dir / "restored.kitti").string();
    map_tool(wrong + " trajectory --format kitti --out " + restored, &rc);
    CHECK(file_text(restored) == file_text(with_wrong_loop));
  }
  SECTION("loopd started on a map whose ledger is newer than its correction corrects it at start") {
    map_json(wrong + " loops --restore " + std::to_string(event), &rc);
    REQUIRE(rc == 0);
    const std::string tiny = (r.dir / "tiny.lcmlog").string(), out = (r.dir / "tiny_out.lcmlog").string();
    log = test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + tiny + " --sensor vlp16 --scans 3 --seed 23 --route block --quiet", &rc);
    REQUIRE(rc == 0);
    log = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --replay " + tiny + " --map " + wrong + " --output " + out, &rc);
    INFO(log);
    REQUIRE(rc == 0);
    CHECK(log.find("the graph was solved again") != std::string::npos);
    j = map_json(wrong + " info", &rc);
    CHECK(j["loops_revoked"] == 0);
    CHECK(j["correction_ledger_seq"] == 2);
    int trajectories = 0;
    LogReader reader;
    std::string error;
    REQUIRE(reader.open(out, &error));
    LogEvent ev;
    while (reader.next(&ev)) trajectories += ev.channel == channels::kTrajectory ? 1 : 0;
    CHECK(trajectories >= 1);  // the new correction was published
  }
}

TEST_CASE("loopd-map check passes on a map, fails on a tampered copy, bad files are refused with exit 2") {
  const ReplayedMap& r = replayed();
  int rc = -1;
  auto j = map_json(r.map + " check", &rc);
  CHECK(rc == 0);
  CHECK(j["ok"] == true);

  SECTION("a loop naming a keyframe the map does not hold: exit 1, the problem named") {
    const std::string copy = altered_copy(r, "tampered.map", kLoopToMissingKeyframe);
    if (copy.empty()) return;
    j = map_json(copy + " check", &rc);
    CHECK(rc == 1);
    CHECK(j["ok"] == false);
    REQUIRE(j["problems"].size() == 1);
    CHECK(j["problems"][0].get<std::string>().find("0/99999") != std::string::npos);
  }

  SECTION("a map of a future schema version and an SQLite file that is not a map: exit 2 with the reason") {
    const std::string future = (r.dir / "future.map").string(), foreign = (r.dir / "foreign.db").string();
    fs::copy_file(r.map, future, fs::copy_options::overwrite_existing);
    if (!sqlite3(future, "PRAGMA user_version = 99") || !sqlite3(foreign, "CREATE TABLE t (x)")) {
      WARN("sqlite3 shell not installed: skipped");
      return;
    }
    std::string log = map_tool(future + " info", &rc);
    CHECK(rc == 2);
    CHECK(log.find("schema version 99") != std::string::npos);
    log = map_tool(foreign + " check", &rc);
    CHECK(rc == 2);
    CHECK(log.find("not a loopd map") != std::string::npos);
  }

  SECTION("garbage, an empty file and a missing file: exit 2 naming the file; the missing one is not created") {
    const std::string garbage = (r.dir / "garbage.map").string(), empty = (r.dir / "empty.map").string();
    const std::string missing = (r.dir / "missing.map").string();
    REQUIRE(test::run_command("head -c 8192 /dev/urandom > " + garbage + " && : > " + empty, &rc).empty());
    for (const std::string& file : {garbage, empty, missing}) {
      for (const std::string command : {"check", "info", "loops", "trajectory --format kitti"}) {
        const std::string log = map_tool(file + " " + command, &rc);
        INFO(command << ": " << log);
        CHECK(rc == 2);
        CHECK(log.find(file) != std::string::npos);
      }
    }
    CHECK_FALSE(fs::exists(missing));
    CHECK(fs::file_size(empty) == 0);
  }
}
