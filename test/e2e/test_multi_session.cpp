// Sessions end to end, as a user runs them: loopd-sim drives a town, loopd maps it into a map file, a second drive
// (another day: another start, heading and odometry frame) is replayed on the same map, and loopd-eval judges both
// against ground truth. Same town: the second session is aligned by loops found without a pose prior; another town:
// no loop between the sessions is taken; an odometry reset mid-drive: the new segment is re-anchored.
#include <catch2/catch.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <unistd.h>

#include <loopd/localization_t.hpp>
#include <loopd/loop_event_t.hpp>
#include <loopd/pose_t.hpp>
#include <loopd/status_t.hpp>

#include "bounded_decode.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "lcm_log.hpp"
#include "support/postgres_server.hpp"
#include "support/run_command.hpp"

namespace fs = std::filesystem;

namespace {
const std::string kBin = LOOPD_BINARY_DIR;

using loopd::test::run_ok;

void simulate(const fs::path& out, int seed, int session, int scans, const std::string& extra = "") {
  run_ok(kBin + "/tools/loopd-sim/loopd-sim --route block --sensor vlp16 --quiet --seed " + std::to_string(seed) + " --session " +
         std::to_string(session) + " --scans " + std::to_string(scans) + " " + extra + " --out " + out.string());
}

void replay(const fs::path& drive, const fs::path& output, const std::string& map) {
  run_ok(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive.string() + " --output " + output.string() + " --map '" + map + "'");
}

nlohmann::json evaluate(const std::string& drives_and_results) {
  return nlohmann::json::parse(loopd::test::last_line(run_ok(kBin + "/tools/loopd-eval/loopd-eval --quiet --json " + drives_and_results)));
}

/// Every message of type Msg on `channel` of a log, in order (those that do not decode are left out).
template <typename Msg>
std::vector<Msg> read_channel(const fs::path& log, const std::string& channel) {
  std::vector<Msg> out;
  loopd::LogReader reader;
  std::string error;
  REQUIRE(reader.open(log.string(), &error));
  loopd::LogEvent e;
  while (reader.next(&e)) {
    Msg m;
    if (e.channel == channel && loopd::decode_bounded(e.data.data(), e.data.size(), loopd::DecodeLimits{}, &m).ok) out.push_back(m);
  }
  return out;
}

/// A message's position and w, x, y, z orientation as a pose.
Eigen::Isometry3d isometry_of(const double position[3], const double orientation[4]) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(orientation[0], orientation[1], orientation[2], orientation[3]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(position[0], position[1], position[2]);
  return T;
}

/// Ground-truth sensor poses of a drive log by utime.
std::map<std::int64_t, Eigen::Isometry3d> ground_truth(const fs::path& drive) {
  std::map<std::int64_t, Eigen::Isometry3d> poses;
  for (const loopd::pose_t& p : read_channel<loopd::pose_t>(drive, "GROUND_TRUTH_POSE")) poses[p.utime] = isometry_of(p.position, p.orientation);
  return poses;
}

/// Accepted loops of an output log between sessions 1 (query) and 0 (match), and how many of them are within 0.5 m /
/// 2 deg of ground truth: the query's pose from the second drive, the match's from the first (same scan times).
struct InterSessionLoops {
  int accepted = 0, correct = 0;
};
InterSessionLoops inter_session_loops(const fs::path& output, const fs::path& first_drive, const fs::path& second_drive) {
  const auto first = ground_truth(first_drive), second = ground_truth(second_drive);
  InterSessionLoops out;
  for (const loopd::loop_event_t& m : read_channel<loopd::loop_event_t>(output, "LOOP_EVENT")) {
    if (m.status != loopd::loop_event_t::STATUS_ACCEPTED || m.query_session == m.match_session) continue;
    ++out.accepted;
    const auto q = second.find(m.query_utime), r = first.find(m.match_utime);
    if (m.query_session != 1 || m.match_session != 0 || q == second.end() || r == first.end()) continue;
    Eigen::Matrix4d T;
    for (int i = 0; i < 16; ++i) T(i / 4, i % 4) = m.T_match_query[i];
    const Eigen::Isometry3d error_T = (r->second.inverse() * q->second).inverse() * Eigen::Isometry3d(T);
    const double deg = Eigen::AngleAxisd(error_T.linear()).angle() * 180.0 / M_PI;
    if (error_T.translation().norm() < 0.5 && deg < 2.0) ++out.correct;
  }
  return out;
}

/// The last status_t of an output log (a replay's final one).
loopd::status_t last_status(const fs::path& output) {
  const std::vector<loopd::status_t> all = read_channel<loopd::status_t>(output, "LOOPD_STATUS");
  return all.empty() ? loopd::status_t{} : all.back();
}

/// Every localization_t of an output log (loopd --localize), in order.
std::vector<loopd::localization_t> localizations(const fs::path& output) { return read_channel<loopd::localization_t>(output, "LOOPD_LOCALIZATION"); }

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

nlohmann::json map_info(const std::string& map) {
  return nlohmann::json::parse(loopd::test::last_line(run_ok(kBin + "/tools/loopd-map/loopd-map --json '" + map + "' info")));
}

/// Starts the test's own PostgreSQL server with a database `name`; false (with a warning: skip) when the server
/// binaries are not installed.
bool start_database(loopd::test::PostgresServer& server, const std::string& name, std::string* uri) {
  if (!server.start()) {
    if (server.binaries_missing()) {
      WARN("PostgreSQL server binaries missing: skipped (" << server.reason() << ")");
      return false;
    }
    FAIL("PostgreSQL test server did not start: " << server.reason());
  }
  *uri = server.create_database(name);
  REQUIRE(!uri->empty());
  return true;
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
  simulate(d / "s2.lcmlog", 3, 2, 400);  // same town, driven the other way round from elsewhere (session 2 of the same seed)
  simulate(d / "x2.lcmlog", 4, 2, 400);  // another town (another seed)

  // Blocks, not SECTIONs: Catch2 would run the 800-scan first drive again for each section.
  {  // --localize: both drives placed in the map without changing it (opened read-only, their keyframes in memory only)
    const std::string before = file_bytes(d / "map.db");
    run_ok(kBin + "/daemon/loopd --sensor vlp16 --quiet --localize --replay " + (d / "s2.lcmlog").string() + " --output " +
           (d / "l2.lcmlog").string() + " --map " + (d / "map.db").string());
    nlohmann::json j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "s2.lcmlog").string() + " --results " +
                                (d / "o1.lcmlog").string() + " --results " + (d / "l2.lcmlog").string());
    INFO(j.dump(1));
    CHECK(j["sessions_aligned"] == 1);
    CHECK(j["inter_session_loops_correct"] == j["inter_session_loops_accepted"]);
    CHECK(j["session_alignment_error_m"].get<double>() < 0.2);
    CHECK(j["session_alignment_error_deg"].get<double>() < 1.0);
    CHECK(j["session_alignment_distance_m"].get<double>() < 30.0);
    // localization_t after every keyframe: localized from some keyframe on, its poses near the drive's ground truth (the
    // map frame is the first drive's, which starts at ground truth).
    const std::vector<loopd::localization_t> placed = localizations(d / "l2.lcmlog");
    const auto truth = ground_truth(d / "s2.lcmlog");
    REQUIRE(placed.size() >= 100);
    CHECK(placed.back().localized);
    CHECK(placed.back().loops_to_map >= 10);
    int localized = 0;
    std::vector<double> error_m, error_deg;
    for (const loopd::localization_t& m : placed) {
      CHECK(m.session == placed.front().session);
      if (!m.localized) continue;
      ++localized;
      CHECK(m.localized_since_utime == placed.back().localized_since_utime);
      const auto gt = truth.find(m.utime);
      REQUIRE(gt != truth.end());
      const Eigen::Isometry3d T_map_vehicle = isometry_of(m.position, m.orientation);
      error_m.push_back((T_map_vehicle.translation() - gt->second.translation()).norm());
      error_deg.push_back(Eigen::AngleAxisd(gt->second.linear().transpose() * T_map_vehicle.linear()).angle() * 180.0 / M_PI);
    }
    std::sort(error_m.begin(), error_m.end());
    std::sort(error_deg.begin(), error_deg.end());
    REQUIRE(error_m.size() >= 20);
    const std::size_t p95 = error_m.size() * 95 / 100;
    INFO(localized << " of " << placed.size() << " keyframes localized; pose error median " << error_m[error_m.size() / 2] << " m / "
                   << error_deg[error_deg.size() / 2] << " deg, p95 " << error_m[p95] << " m / " << error_deg[p95] << " deg, max " << error_m.back()
                   << " m / " << error_deg.back() << " deg");
    CHECK(localized >= static_cast<int>(placed.size()) * 3 / 4);
    // Measured: median 0.24 m / 0.27 deg, p95 0.29 m / 0.42 deg, max 0.34 m / 0.50 deg. The pose is the map's: its own
    // keyframes' error against ground truth comes with it (docs/sessions.md), hence the check against the map below.
    CHECK(error_m[p95] < 0.35);
    CHECK(error_deg[p95] < 1.0);
    // Against the map itself: the vehicle's pose relative to the map keyframe nearest to it (by ground truth), as the
    // map places both, against the same relative pose in ground truth. This leaves the map's own error out.
    const fs::path tum = d / "map.tum";
    run_ok(kBin + "/tools/loopd-map/loopd-map " + (d / "map.db").string() + " trajectory --format tum --out " + tum.string());
    const loopd::TrajectoryFile stored = loopd::read_trajectory(tum.string(), loopd::TrajectoryFormat::kTum);
    REQUIRE(stored.ok);
    const auto truth1 = ground_truth(d / "s1.lcmlog");
    std::vector<std::pair<Eigen::Isometry3d, Eigen::Isometry3d>> map_keyframes;  // (stored, ground truth)
    for (std::size_t i = 0; i < stored.poses.size(); ++i) {
      const auto gt = truth1.find(std::llround(stored.stamps[i] * 1e6));
      if (gt != truth1.end()) map_keyframes.emplace_back(stored.poses[i], gt->second);
    }
    REQUIRE(map_keyframes.size() * 10 >= stored.poses.size() * 9);
    std::vector<double> relative_m, relative_deg;
    for (const loopd::localization_t& m : placed) {
      if (!m.localized) continue;
      const Eigen::Isometry3d& gt = truth.at(m.utime);
      const auto nearest = std::min_element(map_keyframes.begin(), map_keyframes.end(), [&](const auto& a, const auto& b) {
        return (a.second.translation() - gt.translation()).squaredNorm() < (b.second.translation() - gt.translation()).squaredNorm();
      });
      const Eigen::Isometry3d estimated = nearest->first.inverse() * isometry_of(m.position, m.orientation), actual = nearest->second.inverse() * gt;
      relative_m.push_back((estimated.translation() - actual.translation()).norm());
      relative_deg.push_back(Eigen::AngleAxisd(actual.linear().transpose() * estimated.linear()).angle() * 180.0 / M_PI);
    }
    std::sort(relative_m.begin(), relative_m.end());
    std::sort(relative_deg.begin(), relative_deg.end());
    const std::size_t rp95 = relative_m.size() * 95 / 100;
    INFO("pose error against the nearest map keyframe: median "
         << relative_m[relative_m.size() / 2] << " m / " << relative_deg[relative_deg.size() / 2] << " deg, p95 " << relative_m[rp95] << " m / "
         << relative_deg[rp95] << " deg");
    // Measured: median 0.045 m / 0.16 deg, p95 0.12 m / 0.35 deg (issue 33's target, 0.2 m / 1 deg, met against the map).
    CHECK(relative_m[rp95] < 0.2);
    CHECK(relative_deg[rp95] < 1.0);
    run_ok(kBin + "/daemon/loopd --sensor vlp16 --quiet --localize --replay " + (d / "x2.lcmlog").string() + " --output " +
           (d / "lx2.lcmlog").string() + " --map " + (d / "map.db").string());
    j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "x2.lcmlog").string() + " --results " + (d / "o1.lcmlog").string() +
                 " --results " + (d / "lx2.lcmlog").string());
    INFO(j.dump(1));
    CHECK(j["inter_session_loops_accepted"] == 0);  // never localized in a town it has not mapped
    CHECK(j["sessions_aligned"] == 0);
    const std::vector<loopd::localization_t> elsewhere = localizations(d / "lx2.lcmlog");
    CHECK(elsewhere.size() >= 100);
    for (const loopd::localization_t& m : elsewhere) CHECK_FALSE(m.localized);  // and says so
    CHECK(file_bytes(d / "map.db") == before);                                  // the map, byte for byte
    CHECK(map_info((d / "map.db").string())["sessions"] == 1);
  }

  {  // same town, replayed onto the map (a second session stored in it)
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

  {  // another town (another seed): no loop between the sessions
    replay(d / "x2.lcmlog", d / "ox2.lcmlog", d / "other.db");
    const nlohmann::json j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "x2.lcmlog").string() + " --results " +
                                      (d / "o1.lcmlog").string() + " --results " + (d / "ox2.lcmlog").string());
    INFO(j.dump(1));
    CHECK(j["sessions"] == 2);
    CHECK(j["inter_session_loops_accepted"] == 0);
    CHECK(j["sessions_aligned"] == 0);
  }
}

TEST_CASE("a second drive with the first one's scan times is its own session: the same town aligned, another town never") {
  // Two vehicles' logs of the same hour, or a log replayed onto a map made from another: every keyframe is stored in
  // a session of its own, never skipped as if the map held it and never stitched into the first drive's frame.
  TempDir dir("loopd_same_time");
  const fs::path& d = dir.path;
  simulate(d / "s1.lcmlog", 3, 1, 400);
  replay(d / "s1.lcmlog", d / "o1.lcmlog", d / "map.db");
  fs::copy_file(d / "map.db", d / "other.db");
  const nlohmann::json before = map_info(d / "map.db");
  REQUIRE(before["sessions"] == 1);
  const int first_keyframes = before["keyframes"].get<int>();

  {  // the same town from elsewhere, same scan times: aligned through prior-free loops (no SECTIONs: one base run)
    simulate(d / "s2.lcmlog", 3, 2, 300, "--same-day");
    replay(d / "s2.lcmlog", d / "o2.lcmlog", d / "map.db");
    const nlohmann::json after = map_info(d / "map.db");
    INFO(after.dump(1));
    REQUIRE(after["sessions"] == 2);
    CHECK(after["session_list"][1]["first_utime"] == after["session_list"][0]["first_utime"]);  // the same scan times
    CHECK(after["session_list"][1]["anchored"] == true);
    CHECK(after["keyframes"].get<int>() - first_keyframes >= 120);  // 300 scans at 10 m/s, 1 m apart: every keyframe stored
    const InterSessionLoops loops = inter_session_loops(d / "o2.lcmlog", d / "s1.lcmlog", d / "s2.lcmlog");
    CHECK(loops.accepted >= 10);
    CHECK(loops.correct == loops.accepted);
    run_ok(kBin + "/tools/loopd-map/loopd-map " + (d / "map.db").string() + " check");  // exit 0: the invariants hold
  }

  {  // another town, same scan times: its own session, no loop to the first
    simulate(d / "x2.lcmlog", 4, 2, 300, "--same-day");
    replay(d / "x2.lcmlog", d / "ox2.lcmlog", d / "other.db");
    const nlohmann::json after = map_info(d / "other.db");
    INFO(after.dump(1));
    REQUIRE(after["sessions"] == 2);
    CHECK(after["session_list"][1]["anchored"] == false);
    CHECK(after["keyframes"].get<int>() - first_keyframes >= 120);
    CHECK(inter_session_loops(d / "ox2.lcmlog", d / "s1.lcmlog", d / "x2.lcmlog").accepted == 0);
    const loopd::status_t status = last_status(d / "ox2.lcmlog");  // status_t says so
    CHECK(status.session == 1);
    CHECK(status.sessions_opened == 1);
    CHECK(status.keyframes_skipped == 0);
    CHECK(status.map_write_failures == 0);
    // Replayed again onto its map, it is recognised as stored and skipped: nothing new.
    replay(d / "x2.lcmlog", d / "ox2b.lcmlog", d / "other.db");
    CHECK(map_info(d / "other.db")["keyframes"] == after["keyframes"]);
    CHECK(map_info(d / "other.db")["sessions"] == 2);
    const loopd::status_t rerun = last_status(d / "ox2b.lcmlog");
    CHECK(rerun.keyframes_skipped == after["keyframes"].get<int>() - first_keyframes);
    CHECK(rerun.sessions_opened == 0);
    CHECK(rerun.session == 1);
  }
}

TEST_CASE("on a PostgreSQL map, another town's drive with the first one's scan times is its own session, stored whole") {
  loopd::test::PostgresServer server;
  std::string uri;
  if (!start_database(server, "two_drives", &uri)) return;
  TempDir dir("loopd_same_time_pg");
  const fs::path& d = dir.path;
  simulate(d / "s1.lcmlog", 3, 1, 300);
  simulate(d / "x2.lcmlog", 4, 2, 300, "--same-day");
  replay(d / "s1.lcmlog", d / "o1.lcmlog", uri);
  const int first_keyframes = map_info(uri)["keyframes"].get<int>();
  replay(d / "x2.lcmlog", d / "ox2.lcmlog", uri);
  const nlohmann::json after = map_info(uri);
  INFO(after.dump(1));
  REQUIRE(after["sessions"] == 2);
  CHECK(after["session_list"][1]["first_utime"] == after["session_list"][0]["first_utime"]);
  CHECK(after["session_list"][1]["anchored"] == false);
  CHECK(after["keyframes"].get<int>() - first_keyframes >= 120);
  CHECK(inter_session_loops(d / "ox2.lcmlog", d / "s1.lcmlog", d / "x2.lcmlog").accepted == 0);
  const loopd::status_t status = last_status(d / "ox2.lcmlog");
  CHECK(status.sessions_opened == 1);
  CHECK(status.keyframes_skipped == 0);
  CHECK(status.map_write_failures == 0);
}

TEST_CASE("on a PostgreSQL map, --localize through a role with SELECT rights only: localized, every table unchanged") {
  loopd::test::PostgresServer server;
  std::string uri;
  if (!start_database(server, "localize", &uri)) return;
  TempDir dir("loopd_localize_pg");
  const fs::path& d = dir.path;
  simulate(d / "s1.lcmlog", 3, 1, 400);
  simulate(d / "s2.lcmlog", 3, 2, 300);  // the same town another day, from elsewhere, the other way round
  replay(d / "s1.lcmlog", d / "o1.lcmlog", uri);
  // A role that may read the map and nothing else, as a production vehicle would be given.
  REQUIRE(server.sql(uri, "CREATE ROLE map_reader LOGIN PASSWORD 'reader1'; GRANT SELECT ON ALL TABLES IN SCHEMA public TO map_reader"));
  const std::string reader = server.uri_as("map_reader", "reader1", "localize");
  const auto digest = [&] {  // every table's rows, as md5 of its sorted rows
    const std::optional<std::string> tables = server.query(uri, "SELECT tablename FROM pg_tables WHERE schemaname = 'public' ORDER BY 1");
    REQUIRE(tables);
    std::string all;
    std::istringstream lines(*tables);
    for (std::string table; std::getline(lines, table);) {
      const std::optional<std::string> rows =
          server.query(uri, "SELECT count(*) || ' ' || coalesce(md5(string_agg(md5(t::text), '' ORDER BY md5(t::text))), '') FROM " + table + " t");
      REQUIRE(rows);
      all += table + " " + *rows + "\n";
    }
    return all;
  };
  const std::string before = digest();
  INFO(before);
  REQUIRE(before.find("keyframes ") != std::string::npos);

  run_ok(kBin + "/daemon/loopd --sensor vlp16 --quiet --localize --replay " + (d / "s2.lcmlog").string() + " --output " + (d / "l2.lcmlog").string() +
         " --map '" + reader + "'");
  const std::vector<loopd::localization_t> placed = localizations(d / "l2.lcmlog");
  REQUIRE(placed.size() >= 100);
  CHECK(placed.back().localized);
  CHECK(placed.back().loops_to_map >= 10);
  const nlohmann::json j = evaluate("--drive " + (d / "s1.lcmlog").string() + " --drive " + (d / "s2.lcmlog").string() + " --results " +
                                    (d / "o1.lcmlog").string() + " --results " + (d / "l2.lcmlog").string());
  INFO(j.dump(1));
  CHECK(j["sessions_aligned"] == 1);
  CHECK(j["inter_session_loops_correct"] == j["inter_session_loops_accepted"]);
  CHECK(j["session_alignment_error_m"].get<double>() < 0.2);
  CHECK(digest() == before);  // nothing written

  // The same role cannot map: loopd says why and the map stays as it was.
  int rc = 0;
  const std::string out = loopd::test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + (d / "s2.lcmlog").string() +
                                                       " --output " + (d / "m2.lcmlog").string() + " --map '" + reader + "' 2>&1",
                                                   &rc);
  INFO(out);
  CHECK(rc != 0);
  CHECK(out.find("permission denied") != std::string::npos);
  CHECK(digest() == before);
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
  // Against the same drive without the reset: the corrected trajectory is no worse than 1.2x (docs/sessions.md).
  simulate(d / "n.lcmlog", 3, 1, 800);
  replay(d / "n.lcmlog", d / "on.lcmlog", d / "plain.db");
  const nlohmann::json plain = evaluate("--drive " + (d / "n.lcmlog").string() + " --results " + (d / "on.lcmlog").string());
  CHECK(j["ate_after"].get<double>() <= 1.2 * plain["ate_after"].get<double>() + 0.05);
}
