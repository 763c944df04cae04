// loopd-eval on a hand-built drive + results log with known true and false loops: the metrics library and the
// loopd-eval binary must both give the hand-counted precision / recall.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include "loopd/eval/evaluation.hpp"

#if 1  // LCM types and lcm_log.hpp are always linked (loopd_lcm)
#define LOOPD_EVAL_TEST_HAS_LCM 1
#include <loopd/loop_event_t.hpp>
#include <loopd/trajectory_t.hpp>

#include "lcm_log.hpp"
#include "message_convert.hpp"
#endif

using namespace loopd;
namespace fs = std::filesystem;

namespace {

constexpr std::int64_t kUtime0 = 1000000;
constexpr std::int64_t kPeriod = 100000;
std::int64_t utime_of(int frame) { return kUtime0 + frame * kPeriod; }

// Out-and-back route (see test_eval_metrics.cpp): return frame f at x = 299 - f is a true loop with outbound frame
// 299 - f for f >= 200 (0.5 m apart, gap > 100). Heading along the route, so T_match_query has a 180 deg yaw.
Eigen::Isometry3d gt_pose(int f) {
  if (f < 150) return make_isometry(f, 0.0, 0.0, 0.0);
  return make_isometry(299 - f, 0.5, 0.0, M_PI);
}

struct HandLoop {
  int query, match;
  LoopStatus status;
  double descriptor_distance;
  double offset;  // [m] error put into T_match_query; < 0: T_match_query = identity
  const char* stage;
};
// Known verdicts:
//  250->49 accepted, true, exact transform           -> TP, correct
//  260->39 accepted, true, transform 2 m off          -> TP, wrong
//  280->100 accepted, FALSE (81 m apart), T = identity -> FP, wrong
//  120->10 accepted, FALSE (110 m apart), exact T     -> FP, but a CORRECT closure (judged whatever the distance)
//  270->29 rejected, true                             -> only in the PR curve
//  290->150 rejected, false                           -> only in the PR curve
//  295->5 gate rejection, no descriptor               -> nowhere
const HandLoop kLoops[] = {
    {250, 49, LoopStatus::kAccepted, 0.10, 0.0, "accepted"},   {260, 39, LoopStatus::kAccepted, 0.20, 2.0, "accepted"},
    {280, 100, LoopStatus::kAccepted, 0.30, -1.0, "accepted"}, {120, 10, LoopStatus::kAccepted, 0.25, 0.0, "accepted"},
    {270, 29, LoopStatus::kRejected, 0.15, 0.0, "gicp"},       {290, 150, LoopStatus::kRejected, 0.50, 0.0, "fourpcs"},
    {295, 5, LoopStatus::kRejected, -1.0, 0.0, "gate"},
};

EvalInput build_input() {
  EvalInput in;
  for (int f = 0; f < 300; ++f) {
    StampedPose g;
    g.utime = utime_of(f);
    g.T_world_sensor = gt_pose(f);
    in.ground_truth.push_back(g);
    // Odometry: a constant heading drift of 0.1 deg per frame about the start.
    StampedPose o = g;
    o.T_world_sensor = make_isometry(0, 0, 0, f * 0.1 * M_PI / 180.0) * g.T_world_sensor;
    in.odometry.push_back(o);
    in.scan_utimes.push_back(g.utime);
    KeyframePose k;
    k.utime = g.utime;
    k.T_map_sensor = g.T_world_sensor;  // a perfect correction
    in.corrected.push_back(k);
  }
  std::int64_t id = 0;
  for (const auto& h : kLoops) {
    LoopDecision r;
    r.event_id = id++;
    r.query_utime = utime_of(h.query);
    r.match_utime = utime_of(h.match);
    r.status = h.status;
    r.stage = h.stage;
    r.descriptor_distance = h.descriptor_distance;
    r.T_match_query = gt_pose(h.match).inverse() * gt_pose(h.query);
    if (h.offset < 0)
      r.T_match_query = Eigen::Isometry3d::Identity();
    else
      r.T_match_query.translation().x() += h.offset;
    r.ms_descriptor = 10.0 + static_cast<double>(id);
    r.ms_total = 100.0 * static_cast<double>(id);
    in.loops.push_back(r);
  }
  return in;
}

void check_hand_counts(double precision, double recall, int tp, int fp, int fn) {
  CHECK(tp == 2);
  CHECK(fp == 2);
  CHECK(fn == 98);  // 100 ground-truth query keyframes (frames 200..299), two detected
  CHECK(precision == Approx(0.5));
  CHECK(recall == Approx(0.02));
}

}  // namespace

TEST_CASE("metrics library: hand-built loops give the hand-counted detection and closure figures") {
  const EvalInput in = build_input();
  const EvalReport rep = evaluate(in, EvalConfig{});
  REQUIRE(rep.ok);
  CHECK(rep.keyframe_utimes.size() == 300);
  CHECK(rep.detection.gt_queries == 100);
  check_hand_counts(rep.detection.precision, rep.detection.recall, rep.detection.true_positives, rep.detection.false_positives,
                    rep.detection.false_negatives);
  // PR curve over the 6 pairs with a descriptor distance: 0.10 T, 0.15 T, 0.20 T, 0.25 F, 0.30 F, 0.50 F.
  REQUIRE(rep.detection.pr_curve.size() == 6);
  CHECK(rep.detection.pr_curve[2].recall == Approx(0.03));
  CHECK(rep.detection.pr_curve[2].precision == Approx(1.0));
  CHECK(rep.detection.pr_curve[5].precision == Approx(0.5));
  CHECK(rep.detection.max_recall == Approx(0.03));
  CHECK(rep.detection.precision_at_max_recall == Approx(1.0));
  CHECK(rep.detection.f1_max == Approx(2 * 0.03 / 1.03));
  CHECK(rep.detection.f1_max_threshold == Approx(0.2));
  // Closure: 4 accepted, 250->49 and 120->10 within 0.5 m / 2 deg.
  CHECK(rep.closure.accepted == 4);
  CHECK(rep.closure.correct == 2);
  CHECK(rep.closure.precision == Approx(0.5));
  CHECK(rep.closure.recall == Approx(0.03));  // queries 250, 260, 280 are all revisits
  CHECK(rep.closure.recall_correct == Approx(0.01));
  CHECK(rep.closure.stretches == 1);
  CHECK(rep.closure.stretches_closed == 1);
  // Loop transform error of the 4 accepted loops: 0, 0, 2 and 81.0015 m (identity for a 180 deg, 81 m transform).
  CHECK(rep.loop_translation_error.count == 4);
  CHECK(rep.loop_translation_error.median == Approx(1.0));
  CHECK(rep.loop_translation_error.p95 == Approx(std::hypot(81.0, 0.5)));
  CHECK(rep.loop_rotation_error_deg.median == Approx(0.0).margin(1e-9));
  CHECK(rep.loop_rotation_error_deg.p95 == Approx(180.0));
  // Pose error: the corrected trajectory is ground truth; odometry drifts.
  CHECK(rep.error_after.mean < 1e-9);
  CHECK(rep.ate_after < 1e-9);
  CHECK(rep.error_before.mean > 1.0);
  CHECK(rep.ate_before > 1.0);
  CHECK(rep.ms_descriptor.count == 7);
  CHECK(rep.ms_total.max == Approx(700.0));

  // Closure tolerance is configurable: 2.5 m accepts the 2 m-off loop.
  EvalConfig loose;
  loose.closure_max_translation = 2.5;
  CHECK(evaluate(in, loose).closure.correct == 3);
}

TEST_CASE("metrics library: keyframes after the last trajectory revision are added at its spacing") {
  EvalInput in = build_input();
  in.corrected.clear();
  for (int f = 0; f <= 200; ++f) in.corrected.push_back({utime_of(f), gt_pose(f)});
  in.loops.clear();
  const EvalReport rep = evaluate(in, EvalConfig{});
  REQUIRE(rep.ok);
  CHECK(rep.keyframe_utimes.size() == 300);  // 0..200 listed, 201..299 added
  CHECK(rep.detection.gt_queries == 100);    // without the tail only frame 200 would count
  CHECK_FALSE(rep.warnings.empty());
}

#ifdef LOOPD_EVAL_TEST_HAS_LCM
TEST_CASE("loopd-eval binary: same figures from LCM logs, JSON as the last line, pictures written") {
  const EvalInput in = build_input();
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_eval_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string drive = (dir / "drive.lcmlog").string(), results = (dir / "results.lcmlog").string();
  std::string err;
  {
    LogWriter w;
    REQUIRE(w.open(drive, &err));
    for (std::size_t i = 0; i < in.ground_truth.size(); ++i) {
      const std::int64_t u = in.ground_truth[i].utime;
      REQUIRE(w.write_message(channels::kGroundTruth, u, to_message(in.ground_truth[i], static_cast<std::int64_t>(i))));
      REQUIRE(w.write_message(channels::kPose, u, to_message(in.odometry[i], static_cast<std::int64_t>(i))));
      PointCloud c;
      c.points = {{1.f, 2.f, 3.f}, {4.f, 5.f, 6.f}};
      REQUIRE(w.write_message(channels::kScan, u, to_message(c, u, static_cast<std::int64_t>(i), "lidar")));
    }
  }
  {
    LogWriter w;
    REQUIRE(w.open(results, &err));
    // An older, wrong trajectory revision first: the evaluator must use the LAST one.
    for (int rev : {0, 1}) {
      trajectory_t t{};  // value-initialised: num_sessions = 0 (a single-session trajectory without a session list)
      t.utime = utime_of(299);
      t.revision = rev;
      t.loop_event_id = 0;
      t.method = "heuristic";
      to_row_major(Eigen::Isometry3d::Identity(), t.T_map_odom);
      for (std::size_t i = 0; i < in.corrected.size(); ++i) {
        keyframe_pose_t k{};
        k.id = static_cast<std::int64_t>(i);
        k.utime = in.corrected[i].utime;
        const Eigen::Isometry3d T = rev == 0 ? in.odometry[i].T_world_sensor : in.corrected[i].T_map_sensor;
        const Eigen::Quaterniond q(T.linear());
        for (int a = 0; a < 3; ++a) k.position[a] = T.translation()(a);
        k.orientation[0] = q.w();
        k.orientation[1] = q.x();
        k.orientation[2] = q.y();
        k.orientation[3] = q.z();
        t.keyframes.push_back(k);
        t.keyframe_sessions.push_back(0);
      }
      t.num_keyframes = static_cast<std::int32_t>(t.keyframes.size());
      // Revision 1 is a partial message (every pose changed): the evaluator applies it on top of revision 0 by id.
      t.full = rev == 0;
      t.total_keyframes = t.num_keyframes;
      if (rev == 1) {
        for (const auto& l : in.loops) {
          loop_event_t e{};
          e.utime = l.query_utime;
          e.event_id = l.event_id;
          e.query_utime = l.query_utime;
          e.match_utime = l.match_utime;
          e.status = static_cast<std::int8_t>(l.status);
          e.stage = l.stage;
          e.reason = "hand-built";
          e.descriptor_distance = l.descriptor_distance;
          to_row_major(l.T_match_query, e.T_match_query);
          e.ms_descriptor = l.ms_descriptor;
          e.ms_total = l.ms_total;
          REQUIRE(w.write_message(channels::kLoopEvent, e.utime, e));
        }
      }
      REQUIRE(w.write_message(channels::kTrajectory, t.utime, t));
    }
  }
  const std::string bin = std::string(LOOPD_BINARY_DIR) + "/tools/loopd-eval/loopd-eval";
  if (!fs::exists(bin)) {
    WARN("skipped: " << bin << " not built (cmake --build <dir> --target loopd-eval)");
    return;
  }
  const std::string out = (dir / "stdout.txt").string();
  const std::string cmd = bin + " --drive " + drive + " --results " + results + " --json --quiet --plots " + (dir / "plots").string() +
                          " --export-tum " + (dir / "tum").string() + " --export-loops " + (dir / "loops.csv").string() + " > " + out + " 2> " +
                          (dir / "stderr.txt").string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::ifstream f(out);
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty()) last = line;
  const auto j = nlohmann::json::parse(last);
  check_hand_counts(j["precision"], j["recall"], j["true_positives"], j["false_positives"], j["false_negatives"]);
  CHECK(j["closure_precision"].get<double>() == Approx(0.5));
  CHECK(j["closure_recall"].get<double>() == Approx(0.03));
  CHECK(j["stretches_closed"].get<int>() == 1);
  CHECK(j["loop_translation_error_median"].get<double>() == Approx(1.0));
  CHECK(j["loop_translation_error_p95"].get<double>() == Approx(std::hypot(81.0, 0.5)));
  CHECK(j["loop_rotation_error_p95_deg"].get<double>() == Approx(180.0));
  CHECK(j["trajectory_revision"].get<int>() == 1);
  CHECK(j["mean_error_after"].get<double>() < 1e-6);  // positions go through LCM doubles: exact to rounding
  CHECK(j["median_error_before"].get<double>() > 1.0);
  CHECK(j["mean_error_before"].get<double>() == Approx(evaluate(in, EvalConfig{}).error_before.mean).epsilon(1e-6));
  CHECK(j["scans"].get<int>() == 300);
  CHECK(j["timings"]["total"]["max"].get<double>() == Approx(700.0));
  CHECK(fs::exists(dir / "tum" / "corrected.tum"));
  // --export-loops: a line per accepted loop, the error figures' inputs (the worst is the 81 m one).
  std::ifstream loops_csv(dir / "loops.csv");
  std::getline(loops_csv, line);
  CHECK(line.rfind("event_id,query_utime,match_utime,", 0) == 0);
  int rows = 0, correct_rows = 0;
  double worst = 0.0;
  while (std::getline(loops_csv, line)) {
    std::vector<std::string> cells;
    std::stringstream cells_in(line);
    for (std::string cell; std::getline(cells_in, cell, ',');) cells.push_back(cell);
    REQUIRE(cells.size() == 10);
    ++rows;
    correct_rows += cells[9] == "1" ? 1 : 0;
    worst = std::max(worst, std::stod(cells[7]));
  }
  CHECK(rows == j["accepted"].get<int>());
  CHECK(correct_rows == j["correct"].get<int>());
  CHECK(worst == Approx(std::hypot(81.0, 0.5)));
  if (j["pictures"].empty()) {
    WARN("no pictures: gnuplot missing? " << j["warnings"].dump());
  } else {
    CHECK(fs::file_size(dir / "plots" / "trajectories.png") > 1000);
    CHECK(fs::file_size(dir / "plots" / "pr_curve.svg") > 1000);
  }

  // --min-frame-gap 250 keeps only return frames x < 24.5: 25 queries, none detected (x = 49, 39 are out).
  const std::string cmd2 = bin + " --drive " + drive + " --results " + results + " --json --quiet --min-frame-gap 250 > " + out + " 2>/dev/null";
  REQUIRE(std::system(cmd2.c_str()) == 0);
  std::ifstream f2(out);
  while (std::getline(f2, line))
    if (!line.empty()) last = line;
  const auto j2 = nlohmann::json::parse(last);
  CHECK(j2["true_positives"].get<int>() == 0);
  CHECK(j2["false_positives"].get<int>() == 4);
  CHECK(j2["false_negatives"].get<int>() == 25);
  if (std::getenv("LOOPD_KEEP_TEST_OUTPUT"))
    WARN("kept " << dir.string());
  else
    fs::remove_all(dir);
}
namespace {

// Two sessions on one map (see test_eval_metrics.cpp): session 0 drives x = 0..99, session 1 a day later x = -30..69
// on y = 1, tied to the map by a loop at its keyframe 40 (corrected poses 0.5 m / 2 deg off from there on).
constexpr std::int64_t kDay = 86400LL * 1000000LL;
std::int64_t session_utime(int session, int i) { return session * kDay + kUtime0 + i * kPeriod; }
Eigen::Isometry3d session_gt(int session, int i) { return session == 0 ? make_isometry(i, 0, 0, 0) : make_isometry(i - 30.0, 1.0, 0.0, 0.1); }
Eigen::Isometry3d session_corrected(int session, int i) {
  if (session == 0) return session_gt(0, i);
  return i >= 40 ? Eigen::Isometry3d(session_gt(1, i) * make_isometry(0.5, 0, 0, 2.0 * M_PI / 180.0)) : make_isometry(100.0 + i, 0, 0, 0);
}

void write_session_drive(const std::string& path, int session) {
  LogWriter w;
  std::string err;
  REQUIRE(w.open(path, &err));
  for (int i = 0; i < 100; ++i) {
    StampedPose g{session_utime(session, i), session_gt(session, i)};
    StampedPose o{g.utime, session_gt(session, 0).inverse() * g.T_world_sensor};  // its own odometry frame, identity at the start
    REQUIRE(w.write_message(channels::kGroundTruth, g.utime, to_message(g, i)));
    REQUIRE(w.write_message(channels::kPose, g.utime, to_message(o, i)));
    PointCloud c;
    c.points = {{1.f, 2.f, 3.f}};
    REQUIRE(w.write_message(channels::kScan, g.utime, to_message(c, g.utime, i, "lidar")));
  }
}

loop_event_t session_loop(std::int64_t id, int q, int m, int q_session, int m_session, double offset) {
  loop_event_t e{};
  e.event_id = id;
  e.query_id = q;
  e.match_id = m;
  e.query_utime = session_utime(q_session, q);
  e.match_utime = session_utime(m_session, m);
  e.utime = e.query_utime;
  e.query_session = q_session;
  e.match_session = m_session;
  e.status = loop_event_t::STATUS_ACCEPTED;
  e.stage = "accepted";
  e.retrieval = q_session == m_session ? "gate" : "global";
  e.descriptor_distance = 0.1;
  e.place_distance = -1;
  Eigen::Isometry3d T = session_gt(m_session, m).inverse() * session_gt(q_session, q);
  T.translation().y() += offset;
  to_row_major(T, e.T_match_query);
  return e;
}

/// A results log: the final full trajectory of `sessions` sessions, and its loop events.
void write_session_results(const std::string& path, int sessions, bool anchored, const std::vector<loop_event_t>& loops) {
  LogWriter w;
  std::string err;
  REQUIRE(w.open(path, &err));
  for (const auto& e : loops) REQUIRE(w.write_message(channels::kLoopEvent, e.utime, e));
  trajectory_t t{};
  t.utime = session_utime(sessions - 1, 99);
  t.revision = 3;
  t.method = "graph";
  to_row_major(Eigen::Isometry3d::Identity(), t.T_map_odom);
  for (int s = 0; s < sessions; ++s) {
    for (int i = 0; i < 100; ++i) {
      const Eigen::Isometry3d T = session_corrected(s, i);
      const Eigen::Quaterniond q(T.linear());
      keyframe_pose_t k{};
      k.id = i;
      k.utime = session_utime(s, i);
      for (int a = 0; a < 3; ++a) k.position[a] = T.translation()(a);
      k.orientation[0] = q.w();
      k.orientation[1] = q.x();
      k.orientation[2] = q.y();
      k.orientation[3] = q.z();
      t.keyframes.push_back(k);
      t.keyframe_sessions.push_back(s);
    }
    session_alignment_t a{};
    a.session = s;
    a.anchored = s == 0 || anchored;
    to_row_major(Eigen::Isometry3d::Identity(), a.T_map_session);
    a.num_keyframes = 100;
    t.sessions.push_back(a);
  }
  t.num_keyframes = static_cast<std::int32_t>(t.keyframes.size());
  t.num_sessions = static_cast<std::int32_t>(t.sessions.size());
  t.full = true;
  t.total_keyframes = t.num_keyframes;
  REQUIRE(w.write_message(channels::kTrajectory, t.utime, t));
}

nlohmann::json run_eval_json(const std::string& args, const fs::path& dir) {
  const std::string bin = std::string(LOOPD_BINARY_DIR) + "/tools/loopd-eval/loopd-eval";
  const std::string out = (dir / "stdout.txt").string();
  const std::string cmd = bin + " " + args + " --json --quiet > " + out + " 2> " + (dir / "stderr.txt").string();
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::ifstream f(out);
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty()) last = line;
  return nlohmann::json::parse(last);
}

}  // namespace

TEST_CASE("loopd-eval binary: two drives and two results logs of a two-session map give the session figures") {
  if (!fs::exists(std::string(LOOPD_BINARY_DIR) + "/tools/loopd-eval/loopd-eval")) {
    WARN("skipped: loopd-eval not built");
    return;
  }
  const fs::path dir = fs::temp_directory_path() / ("loopd_test_eval_sessions_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string d1 = (dir / "s1.lcmlog").string(), d2 = (dir / "s2.lcmlog").string();
  const std::string o1 = (dir / "o1.lcmlog").string(), o2 = (dir / "o2.lcmlog").string(), o2u = (dir / "o2u.lcmlog").string();
  write_session_drive(d1, 0);
  write_session_drive(d2, 1);
  // Run 1: one session, one loop within it. Run 2: the resumed map (both sessions), loops 1->0 at keyframe 40
  // (exact) and 60 (1 m off: wrong), and one within session 1.
  write_session_results(o1, 1, true, {session_loop(0, 90, 10, 0, 0, 0.0)});
  const std::vector<loop_event_t> run2 = {session_loop(0, 40, 70, 1, 0, 0.0), session_loop(1, 60, 90, 1, 0, 1.0), session_loop(2, 99, 10, 1, 1, 0.0)};
  write_session_results(o2, 2, true, run2);
  write_session_results(o2u, 2, false, {session_loop(2, 99, 10, 1, 1, 0.0)});

  // The drives in either order, and the results logs in either order: the same figures.
  for (const std::string& args : {"--drive " + d1 + " --drive " + d2 + " --results " + o1 + " --results " + o2,
                                  "--drive " + d2 + " --drive " + d1 + " --results " + o2 + " --results " + o1}) {
    const auto j = run_eval_json(args, dir);
    CHECK(j["keyframes"].get<int>() == 200);
    CHECK(j["scans"].get<int>() == 200);
    CHECK(j["loop_events"].get<int>() == 4);
    CHECK(j["accepted"].get<int>() == 4);
    CHECK(j["correct"].get<int>() == 3);
    CHECK(j["sessions"].get<int>() == 2);
    CHECK(j["sessions_aligned"].get<int>() == 1);
    CHECK(j["sessions_unaligned"].get<int>() == 0);
    CHECK(j["inter_session_loops_accepted"].get<int>() == 2);
    CHECK(j["inter_session_loops_correct"].get<int>() == 1);
    CHECK(j["session_alignment_error_m"].get<double>() == Approx(0.5).epsilon(1e-6));
    CHECK(j["session_alignment_error_deg"].get<double>() == Approx(2.0).epsilon(1e-6));
    CHECK(j["session_alignment_distance_m"].get<double>() == Approx(20.0));
    REQUIRE(j["session_stats"].size() == 2);
    CHECK(j["session_stats"][1]["alignment_samples"].get<int>() == 60);
    CHECK(j["session_stats"][1]["drive"].get<int>() == (args.rfind("--drive " + d1, 0) == 0 ? 2 : 1));
  }
  // Session 1 never anchored: null figures, counted as unaligned.
  const auto u = run_eval_json("--drive " + d1 + " --drive " + d2 + " --results " + o2u, dir);
  CHECK(u["sessions"].get<int>() == 2);
  CHECK(u["sessions_aligned"].get<int>() == 0);
  CHECK(u["sessions_unaligned"].get<int>() == 1);
  CHECK(u["inter_session_loops_accepted"].get<int>() == 0);
  CHECK(u["session_alignment_error_m"].is_null());
  CHECK(u["session_alignment_error_deg"].is_null());
  CHECK(u["session_alignment_distance_m"].is_null());
  if (std::getenv("LOOPD_KEEP_TEST_OUTPUT"))
    WARN("kept " << dir.string());
  else
    fs::remove_all(dir);
}
#else
TEST_CASE("loopd-eval binary (skipped: test not linked to loopd_lcm)") { WARN("skipped: no LCM headers"); }
#endif
