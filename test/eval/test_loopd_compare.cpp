// loopd-compare on real loopd output: two replays of one simulated drive compare identical; copies of one replay
// with a loop decision or a keyframe pose altered (written with LogWriter) are reported with the right counts and
// differences; missing, foreign and damaged logs give a clear error or a warning, never a crash.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <loopd/loop_event_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "loopd/base/pose.hpp"
#include "loopd/records/keyframe_key.hpp"
#include "message_convert.hpp"
#include "support/run_command.hpp"

using namespace loopd;
namespace fs = std::filesystem;

namespace {

const std::string kBin = LOOPD_BINARY_DIR;
const std::string kCompare = kBin + "/tools/loopd-compare/loopd-compare";

/// Two replays of one simulated VLP-16 drive, made once per process and removed at its end.
struct TwoRuns {
  fs::path dir = fs::temp_directory_path() / ("loopd_test_compare_" + std::to_string(::getpid()));
  std::string out1 = (dir / "out1.lcmlog").string(), out2 = (dir / "out2.lcmlog").string();

  TwoRuns() {
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string drive = (dir / "drive.lcmlog").string();
    int rc = 0;
    std::string log =
        test::run_command(kBin + "/tools/loopd-sim/loopd-sim --out " + drive + " --sensor vlp16 --scans 340 --seed 11 --route block --quiet", &rc);
    INFO(log);
    REQUIRE(rc == 0);
    for (const std::string& out : {out1, out2}) {
      log = test::run_command(kBin + "/daemon/loopd --sensor vlp16 --quiet --replay " + drive + " --output " + out, &rc);
      INFO(log);
      REQUIRE(rc == 0);
    }
    fs::remove(drive);  // 150 MB; only the outputs are compared
  }
  ~TwoRuns() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  TwoRuns(const TwoRuns&) = delete;
  TwoRuns& operator=(const TwoRuns&) = delete;
};

const TwoRuns& two_runs() {
  static const TwoRuns runs;
  return runs;
}

/// Runs loopd-compare; its exit status in `rc`, its --json object returned.
nlohmann::json compare(const std::string& a, const std::string& b, int* rc, const std::string& extra = "") {
  const std::string log = test::run_command(kCompare + " --json " + extra + " " + a + " " + b, rc);
  INFO(log);
  const auto j = nlohmann::json::parse(test::last_line(log), nullptr, false);
  REQUIRE_FALSE(j.is_discarded());
  return j;
}

/// Copies a log event by event; `edit` may change an event's bytes (and returns whether it did).
using EditFn = std::function<bool(const LogEvent&, std::vector<std::uint8_t>*)>;

int copy_log(const std::string& from, const std::string& to, const EditFn& edit, std::int64_t junk_after_event = -1) {
  LogReader reader;
  LogWriter writer;
  std::string error;
  REQUIRE(reader.open(from, &error));
  REQUIRE(writer.open(to, &error));
  LogEvent ev;
  int edited = 0;
  std::int64_t n = 0;
  while (reader.next(&ev)) {
    std::vector<std::uint8_t> data = ev.data;
    if (edit && edit(ev, &data)) ++edited;
    REQUIRE(writer.write(ev.channel, ev.timestamp, data.data(), data.size()));
    if (n++ == junk_after_event) {
      const std::vector<std::uint8_t> junk(100, 0x55);
      REQUIRE(writer.append_bytes(junk.data(), junk.size()));
    }
  }
  return edited;
}

template <typename Msg>
std::vector<std::uint8_t> encoded(const Msg& msg) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  REQUIRE(msg.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()));
  return buf;
}

/// Highest corrected trajectory revision in a log.
std::int64_t last_revision(const std::string& path) {
  LogReader reader;
  std::string error;
  REQUIRE(reader.open(path, &error));
  LogEvent ev;
  trajectory_t t;
  std::int64_t rev = -1;
  while (reader.next(&ev))
    if (ev.channel == channels::kTrajectory && LogReader::decode(ev, &t)) rev = std::max(rev, t.revision);
  return rev;
}

}  // namespace

TEST_CASE("loopd-compare: two replays of one drive are identical, altered copies differ by what was altered") {
  const TwoRuns& runs = two_runs();
  int rc = -1;

  // Two replays of the same drive: the same decisions and poses.
  const auto same = compare(runs.out1, runs.out2, &rc);
  CHECK(rc == 0);
  CHECK(same["identical"] == true);
  CHECK(same["events_a"].get<int>() > 0);
  CHECK(same["events_a"] == same["events_b"]);
  const int accepted = same["accepted_a"].get<int>();
  CHECK(accepted >= 5);  // the block route's second visit closes loops
  CHECK(same["accepted_b"] == accepted);
  CHECK(same["accepted_both"] == accepted);
  CHECK(same["trajectory_keyframes_a"].get<int>() > 50);
  CHECK(same["same_keyframe_ids"] == true);
  CHECK(same["max_pose_translation_diff_m"].get<double>() == 0.0);

  SECTION("one accepted event's match id changed: one pair accepted only in each, nothing else") {
    const std::string altered = (runs.dir / "match_id.lcmlog").string();
    std::int64_t query = -1, old_match = -1, new_match = -1;
    const int edited = copy_log(runs.out1, altered, [&](const LogEvent& ev, std::vector<std::uint8_t>* data) {
      loop_event_t e;
      if (query >= 0 || ev.channel != channels::kLoopEvent || !LogReader::decode(ev, &e)) return false;
      if (e.status != loop_event_t::STATUS_ACCEPTED) return false;
      query = e.query_id;
      old_match = e.match_id;
      e.match_id = new_match = e.match_id + 1000000;  // no keyframe has this id
      *data = encoded(e);
      return true;
    });
    REQUIRE(edited == 1);
    const auto j = compare(runs.out1, altered, &rc);
    CHECK(rc == 1);
    CHECK(j["identical"] == false);
    CHECK(j["events_a"] == j["events_b"]);
    CHECK(j["accepted_a"] == accepted);
    CHECK(j["accepted_b"] == accepted);
    CHECK(j["accepted_both"] == accepted - 1);
    CHECK(j["accepted_only_a"] == 1);
    CHECK(j["accepted_only_b"] == 1);
    CHECK(j["accepted_only_a_pairs"] == nlohmann::json::array({{query, old_match}}));
    CHECK(j["accepted_only_b_pairs"] == nlohmann::json::array({{query, new_match}}));
    CHECK(j["decisions_differ"] == 0);
    CHECK(j["max_loop_translation_diff_m"].get<double>() == 0.0);
    CHECK(j["max_pose_translation_diff_m"].get<double>() == 0.0);  // the trajectory was not touched
  }

  SECTION("one keyframe of the last trajectory shifted by 1 cm: a 0.01 m pose difference; 2 cm tolerance accepts it") {
    const std::string altered = (runs.dir / "pose.lcmlog").string();
    const std::int64_t last = last_revision(runs.out1);
    REQUIRE(last >= 0);
    const int edited = copy_log(runs.out1, altered, [&](const LogEvent& ev, std::vector<std::uint8_t>* data) {
      trajectory_t t;
      // The full snapshot of the last revision (the end of the replay) is the trajectory loopd-compare rebuilds last.
      if (ev.channel != channels::kTrajectory || !LogReader::decode(ev, &t) || t.revision != last || !t.full) return false;
      REQUIRE(t.keyframes.size() > 10);
      t.keyframes[10].position[1] += 0.01;
      *data = encoded(t);
      return true;
    });
    REQUIRE(edited == 1);
    auto j = compare(runs.out1, altered, &rc);
    CHECK(rc == 1);
    CHECK(j["identical"] == false);
    CHECK(j["max_pose_translation_diff_m"].get<double>() == Approx(0.01).margin(1e-9));
    CHECK(j["max_pose_rotation_diff_deg"].get<double>() == 0.0);
    CHECK(j["same_keyframe_ids"] == true);
    CHECK(j["accepted_only_a"] == 0);
    CHECK(j["accepted_only_b"] == 0);
    CHECK(j["decisions_differ"] == 0);
    j = compare(runs.out1, altered, &rc, "--tolerance-m 0.02");
    CHECK(rc == 0);
    CHECK(j["identical"] == true);
  }

  SECTION("an accepted loop's transform turned by 0.5 deg and a rejection made an acceptance: both reported") {
    const std::string altered = (runs.dir / "loop.lcmlog").string();
    bool turned = false, flipped = false;
    const int edited = copy_log(runs.out1, altered, [&](const LogEvent& ev, std::vector<std::uint8_t>* data) {
      loop_event_t e;
      if (ev.channel != channels::kLoopEvent || !LogReader::decode(ev, &e)) return false;
      if (!turned && e.status == loop_event_t::STATUS_ACCEPTED) {
        const Eigen::Isometry3d T = from_row_major(e.T_match_query) * make_isometry(0, 0, 0, 0.5 * M_PI / 180.0);
        to_row_major(T, e.T_match_query);
        turned = true;
      } else if (!flipped && e.status == loop_event_t::STATUS_REJECTED) {
        e.status = loop_event_t::STATUS_ACCEPTED;
        e.stage = "accepted";
        flipped = true;
      } else {
        return false;
      }
      *data = encoded(e);
      return true;
    });
    REQUIRE(turned);
    REQUIRE(flipped);  // the drive has rejected loops
    REQUIRE(edited == 2);
    const auto j = compare(runs.out1, altered, &rc);
    CHECK(rc == 1);
    CHECK(j["max_loop_rotation_diff_deg"].get<double>() == Approx(0.5).margin(1e-9));
    CHECK(j["max_loop_translation_diff_m"].get<double>() < 1e-9);  // turned about the query origin
    CHECK(j["accepted_b"] == accepted + 1);
    CHECK(j["accepted_only_b"] == 1);
    CHECK(j["accepted_only_a"] == 0);
    CHECK(j["decisions_differ"] == 1);
    REQUIRE(j["decisions_differ_first"].size() == 1);
    CHECK(j["decisions_differ_first"][0]["b"] == "accepted/accepted");
  }

  SECTION("a damaged copy: the skipped bytes are reported and the rest still compares identical") {
    const std::string damaged = (runs.dir / "damaged.lcmlog").string();
    copy_log(runs.out1, damaged, nullptr, 5);
    const std::string log = test::run_command(kCompare + " --json " + runs.out1 + " " + damaged, &rc);
    INFO(log);
    CHECK(rc == 0);
    CHECK(log.find("warning: B " + damaged + ": damaged log") != std::string::npos);
    const auto j = nlohmann::json::parse(test::last_line(log));
    CHECK(j["identical"] == true);
    CHECK(j["problems_a"] == "");
    CHECK(j["problems_b"].get<std::string>().find("bytes skipped") != std::string::npos);
  }
}

TEST_CASE("loopd-compare: a missing file, a file that is not a loopd log and bad options exit 2 naming the problem") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_compare_bad_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string missing = (dir / "missing.lcmlog").string(), text = (dir / "notes.txt").string();
  std::ofstream(text) << "not an lcm log\n";
  int rc = -1;
  std::string log = test::run_command(kCompare + " " + missing + " " + text, &rc);
  CHECK(rc == 2);
  CHECK(log.find("cannot open LCM log " + missing) != std::string::npos);
  log = test::run_command(kCompare + " " + text + " " + text, &rc);
  CHECK(rc == 2);
  CHECK(log.find(text + ": no 'LOOP_EVENT' or 'CORRECTED_TRAJECTORY' events") != std::string::npos);
  log = test::run_command(kCompare + " " + text, &rc);  // B missing
  CHECK(rc == 2);
  log = test::run_command(kCompare + " --tolerance-m -1 " + text + " " + text, &rc);
  CHECK(rc == 2);
  fs::remove_all(dir);
}

namespace {

/// A loopd output log of two sessions whose keyframe ids repeat (ids count from 0 in each session): one accepted loop
/// from `loop_query` to keyframe 0/3, and one full trajectory with keyframes 0/5 at x = 0 and 1/5 at x = `x_1_5`.
void write_two_session_log(const std::string& path, KeyframeKey loop_query, double x_1_5) {
  LogWriter writer;
  std::string error;
  REQUIRE(writer.open(path, &error));
  loop_event_t e{};
  e.event_id = 1;
  e.status = loop_event_t::STATUS_ACCEPTED;
  e.stage = "accepted";
  e.query_session = loop_query.session;
  e.query_id = loop_query.index;
  e.match_session = 0;
  e.match_id = 3;
  to_row_major(Eigen::Isometry3d::Identity(), e.T_match_query);
  REQUIRE(writer.write_message(channels::kLoopEvent, 1, e));
  trajectory_t t{};
  t.revision = 1;
  t.full = true;
  t.method = "graph";
  for (const auto& [session, x] : {std::pair<std::int32_t, double>{0, 0.0}, {1, x_1_5}}) {
    keyframe_pose_t k{};
    k.id = 5;
    k.position[0] = x;
    k.orientation[0] = 1.0;
    t.keyframes.push_back(k);
    t.keyframe_sessions.push_back(session);
  }
  t.num_keyframes = 2;
  t.total_keyframes = 2;
  REQUIRE(writer.write_message(channels::kTrajectory, 2, t));
  writer.close();
}

}  // namespace

TEST_CASE("loopd-compare: keyframes and loops are named by (session, id), so two sessions' equal ids are not mixed up") {
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_compare_sessions_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string a = (dir / "a.lcmlog").string(), same = (dir / "same.lcmlog").string(), moved = (dir / "moved.lcmlog").string(),
                    other = (dir / "other.lcmlog").string();
  write_two_session_log(a, {1, 5}, 10.0);
  write_two_session_log(same, {1, 5}, 10.0);
  write_two_session_log(moved, {1, 5}, 11.0);  // keyframe 1/5 one metre on; 0/5 (the same id) where it was
  write_two_session_log(other, {2, 5}, 10.0);  // the loop from keyframe 5 of session 2, not of session 1
  int rc = -1;
  nlohmann::json j = compare(a, same, &rc);
  CHECK(rc == 0);
  CHECK(j["identical"] == true);
  j = compare(a, moved, &rc);
  CHECK(rc == 1);
  CHECK(j["max_pose_translation_diff_m"].get<double>() == Approx(1.0));
  CHECK(j["accepted_both"] == 1);
  j = compare(a, other, &rc);
  CHECK(rc == 1);
  CHECK(j["accepted_both"] == 0);
  CHECK(j["accepted_only_a_pairs"] == nlohmann::json::array({{1, 5, 0, 3}}));
  CHECK(j["accepted_only_b_pairs"] == nlohmann::json::array({{2, 5, 0, 3}}));
  CHECK(j["max_pose_translation_diff_m"].get<double>() == 0.0);
  fs::remove_all(dir);
}
