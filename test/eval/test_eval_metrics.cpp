// Metrics of loopd_eval on hand-built trajectories with hand-computed answers.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <tuple>

#include "loopd/eval/evaluation.hpp"
#include "loopd/eval/loop_ground_truth.hpp"
#include "loopd/eval/odometry_drift.hpp"
#include "loopd/eval/pose_error.hpp"
#include "loopd/eval/session_metrics.hpp"

using namespace loopd;

namespace {
// Out-and-back route: frames 0..149 drive x = 0..149 (y = 0); frames 150..299 come back x = 149..0 on y = 0.5
// (z = back_z). Return frame f at x = 299 - f meets outbound frame x at distance 0.5 m, frame gap 299 - 2x.
std::vector<Eigen::Vector3d> out_and_back(double back_z) {
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 150; ++i) p.emplace_back(i, 0.0, 0.0);
  for (int i = 150; i < 300; ++i) p.emplace_back(299 - i, 0.5, back_z);
  return p;
}
std::vector<std::int64_t> iota_frames(std::size_t n) {
  std::vector<std::int64_t> f(n);
  for (std::size_t i = 0; i < n; ++i) f[i] = static_cast<std::int64_t>(i);
  return f;
}
}  // namespace

TEST_CASE("loop ground truth: 1 m and more than 100 frames apart (Vlaminck 2019, 5.3)") {
  const auto pos = out_and_back(0.0);
  LoopGroundTruthConfig cfg;  // 1 m, 100 frames
  const LoopGroundTruth gt = compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg);
  // Return frames with x <= 99 (gap 299 - 2x > 100), i.e. frames 200..299, each with exactly one partner.
  CHECK(gt.num_queries == 100);
  CHECK(gt.num_pairs == 100);
  CHECK_FALSE(gt.revisit[199]);
  REQUIRE(gt.revisit[200]);
  CHECK(gt.partners[200] == std::vector<int>{99});
  CHECK(gt.partners[299] == std::vector<int>{0});
  REQUIRE(gt.stretches.size() == 1);
  CHECK(gt.stretches[0] == std::make_pair(200, 299));

  cfg.min_frame_gap = 250;  // only x < 24.5 remain
  CHECK(compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg).num_queries == 25);
  cfg = {};
  cfg.max_distance = 0.4;  // 0.5 m lane offset: no loop
  CHECK(compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg).num_pairs == 0);
}

TEST_CASE("loop ground truth: 3D versus ground-plane distance") {
  const auto pos = out_and_back(2.0);  // return leg 2 m higher (KITTI-like height error)
  LoopGroundTruthConfig cfg;
  CHECK(compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg).num_pairs == 0);
  cfg.planar = true;
  CHECK(compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg).num_pairs == 100);
  CHECK(place_distance({0, 0, 0}, {3, 4, 12}, cfg) == Approx(5.0));
  cfg.planar = false;
  CHECK(place_distance({0, 0, 0}, {3, 4, 12}, cfg) == Approx(13.0));
  cfg.min_frame_gap = -1;
  CHECK(cfg.validate().has_value());
}

TEST_CASE("closest-pose error matches a hand computation (Vlaminck 2019, Table 4)") {
  std::vector<Eigen::Vector3d> gt;
  for (int i = 0; i <= 10; ++i) gt.emplace_back(i, 0, 0);
  const std::vector<Eigen::Vector3d> est = {{0.5, 1, 0}, {3, -2, 0}, {20, 0, 0}, {7, 0, 0.25}};
  const auto e = closest_pose_errors(est, gt);
  REQUIRE(e.size() == 4);
  CHECK(e[0] == Approx(std::sqrt(1.25)));
  CHECK(e[1] == Approx(2.0));
  CHECK(e[2] == Approx(10.0));
  CHECK(e[3] == Approx(0.25));
  const ErrorStats s = error_stats(e);
  CHECK(s.mean == Approx((std::sqrt(1.25) + 2.0 + 10.0 + 0.25) / 4));
  CHECK(s.median == Approx((std::sqrt(1.25) + 2.0) / 2));
  CHECK(s.max == Approx(10.0));

  // Brute force agrees on random data.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 300; ++i) a.emplace_back(u(rng), u(rng), 0.1 * u(rng));
  for (int i = 0; i < 200; ++i) b.emplace_back(u(rng), u(rng), 0.1 * u(rng));
  const auto fast = closest_pose_errors(b, a);
  for (std::size_t i = 0; i < b.size(); ++i) {
    double best = 1e9;
    for (const auto& g : a) best = std::min(best, (g - b[i]).norm());
    REQUIRE(fast[i] == Approx(best).margin(1e-12));
  }
}

TEST_CASE("Umeyama alignment recovers a known transform, ATE of an aligned copy is zero") {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-20, 20);
  std::vector<Eigen::Vector3d> src, dst;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(12.0, -4.5, 3.25);
  for (int i = 0; i < 50; ++i) {
    src.emplace_back(u(rng), u(rng), u(rng));
    dst.push_back(T * src.back());
  }
  const Eigen::Isometry3d R = umeyama_alignment(src, dst);
  CHECK((R.translation() - T.translation()).norm() < 1e-9);
  CHECK(rotation_angle(Eigen::Isometry3d(R.linear().transpose() * T.linear())) < 1e-9);
  CHECK(ate_rmse(src, dst) < 1e-9);

  // With noise: still within a few millimetres, and ATE about the noise level.
  std::normal_distribution<double> n(0.0, 0.01);
  for (auto& p : dst) p += Eigen::Vector3d(n(rng), n(rng), n(rng));
  const Eigen::Isometry3d Rn = umeyama_alignment(src, dst);
  CHECK((Rn.translation() - T.translation()).norm() < 0.01);
  CHECK(ate_rmse(src, dst) == Approx(0.01 * std::sqrt(3.0)).epsilon(0.3));

  // Scale variant.
  double s = 0;
  std::vector<Eigen::Vector3d> scaled;
  for (const auto& p : src) scaled.push_back(T * (2.5 * p));
  umeyama_alignment(src, scaled, &s, true);
  CHECK(s == Approx(2.5));
}

TEST_CASE("relative error and pose lookup by utime") {
  const Eigen::Isometry3d a = make_isometry(1, 2, 3, 0.3);
  const Eigen::Isometry3d b = a * make_isometry(0.3, 0.4, 0, 2.0 * M_PI / 180.0);
  const RelativeError e = relative_error(b, a);
  CHECK(e.translation == Approx(0.5));
  CHECK(e.rotation_deg == Approx(2.0));

  std::vector<StampedPose> poses(3);
  for (int i = 0; i < 3; ++i) {
    poses[static_cast<std::size_t>(i)].utime = 1000000 + i * 100000;
    poses[static_cast<std::size_t>(i)].T_world_sensor = make_isometry(10.0 * i, 0, 0, 0);
  }
  CHECK(pose_at(poses, 1100000)->translation().x() == Approx(10.0));
  CHECK(pose_at(poses, 1125000)->translation().x() == Approx(12.5));
  CHECK(pose_at(poses, 1250000, 1000000, 100000)->translation().x() == Approx(20.0));  // nearest, 50 ms after
  CHECK_FALSE(pose_at(poses, 1500000, 1000000, 100000).has_value());
}

TEST_CASE("precision-recall curve over the descriptor threshold") {
  // Distances, truth and gt query keyframe: two true detections of query 5, one of query 7, two false.
  const std::vector<double> d = {0.4, 0.1, 0.2, 0.3, 0.2};
  const std::vector<bool> t = {true, true, false, true, true};
  const std::vector<int> q = {9, 5, -1, 5, 7};
  const auto c = precision_recall_curve(d, t, q, 4);
  REQUIRE(c.size() == 4);  // thresholds 0.1, 0.2 (tie), 0.3, 0.4
  CHECK(c[0].precision == Approx(1.0));
  CHECK(c[0].recall == Approx(0.25));
  CHECK(c[1].threshold == Approx(0.2));
  CHECK(c[1].precision == Approx(2.0 / 3.0));
  CHECK(c[1].recall == Approx(0.5));
  CHECK(c[2].recall == Approx(0.5));  // a second detection of query 5 adds no recall
  CHECK(c[2].precision == Approx(0.75));
  CHECK(c[3].recall == Approx(0.75));
  CHECK(c[3].precision == Approx(0.8));
}

TEST_CASE("injected odometry drift is deterministic and grows with distance") {
  std::vector<Eigen::Isometry3d> gt;
  for (int i = 0; i < 500; ++i) gt.push_back(make_isometry(1.0 * i, 0, 0, 0));
  OdometryDriftConfig cfg;
  const auto a = inject_odometry_drift(gt, cfg);
  const auto b = inject_odometry_drift(gt, cfg);
  REQUIRE(a.poses.size() == 500);
  CHECK(a.poses[0].isApprox(gt[0]));
  CHECK(a.poses.back().isApprox(b.poses.back()));
  const double e100 = (a.poses[100].translation() - gt[100].translation()).norm();
  const double e499 = (a.poses[499].translation() - gt[499].translation()).norm();
  CHECK(e499 > e100);
  CHECK(e499 > 2.0);  // 0.005 deg/m heading bias over 500 m: about 11 m lateral, plus 1% scale: 5 m
  CHECK(e499 < 30.0);
  CHECK(a.residuals[1] > cfg.residual_base);
}

#include "loopd/base/trajectory_io.hpp"
#include "loopd/io/kitti_files.hpp"
#include "support/data_dir.hpp"

TEST_CASE("loop ground truth on the real KITTI poses matches the counts in the data README") {
  LOOPD_REQUIRE_DATA(poses00, "kitti/poses/00.txt");
  LOOPD_REQUIRE_DATA(poses02, "kitti/poses/02.txt");
  LOOPD_REQUIRE_DATA(poses05, "kitti/poses/05.txt");
  LOOPD_REQUIRE_DATA(calib, "kitti/calib/Tr_velo_to_cam_00-02.txt");
  auto count = [&calib](const std::string& path, bool lidar, bool planar) {
    const TrajectoryFile cam = read_trajectory(path, TrajectoryFormat::kKitti);
    REQUIRE(cam.ok);
    const KittiCalibration Tr = read_kitti_calib_tr(calib);
    REQUIRE(Tr.ok);
    const auto poses = lidar ? kitti_camera_to_lidar(cam.poses, Tr.T_cam_velo) : cam.poses;
    std::vector<Eigen::Vector3d> pos;
    for (const auto& T : poses) pos.push_back(T.translation());
    LoopGroundTruthConfig cfg;
    cfg.planar = planar;
    cfg.up_axis = lidar ? 2 : 1;  // camera frame: y points down
    return compute_loop_ground_truth(pos, iota_frames(pos.size()), cfg);
  };
  // README (camera positions): 1565 pairs / 556 query frames in 00, 12 in 02 (326 in the ground plane), 853 in 05.
  const auto g00 = count(poses00, false, false);
  CHECK(g00.num_pairs == 1565);
  CHECK(g00.num_queries == 556);
  CHECK(count(poses02, false, false).num_pairs == 12);
  CHECK(count(poses02, false, true).num_pairs == 326);
  CHECK(count(poses05, false, false).num_pairs == 853);
  // Lidar positions (T_world_velo = Tr^-1 P Tr, what loopd-eval uses) sit 0.27 m from the camera: a few pairs differ.
  const auto l00 = count(poses00, true, false);
  CHECK(l00.num_pairs == 1559);
  CHECK(l00.num_queries == 554);
}

namespace {
// Two sessions of the same town: session 0 drives x = 0..99 (y = 0) and is the map; session 1, a day later, drives
// x = -30..69 on y = 1 and enters the mapped area (10 m of a session-0 keyframe) at x = -9. Its first accepted
// inter-session loop is at keyframe 40 (x = 10); from there its corrected poses are ground truth * E (0.5 m, 2 deg
// off in the keyframe's own frame), before it 100 m off (an unanchored session's arbitrary placement).
constexpr std::int64_t kDay = 86400LL * 1000000LL;
const Eigen::Isometry3d kE = make_isometry(0.5, 0.0, 0.0, 2.0 * M_PI / 180.0);

struct TwoSessions {
  std::vector<SessionKeyframe> keyframes;
  std::vector<StampedPose> ground_truth;
};

TwoSessions two_sessions(int sessions = 2) {
  TwoSessions t;
  for (int s = 0; s < sessions; ++s)
    for (int i = 0; i < 100; ++i) {
      SessionKeyframe k;
      k.session = s;
      k.utime = s * kDay + 1000000 + i * 100000;
      k.T_world = s == 0 ? make_isometry(i, 0, 0, 0) : make_isometry(i - 30.0, 1.0, 0.0, 0.1 * s);
      k.T_map = s == 0 ? k.T_world : (i >= 40 ? Eigen::Isometry3d(k.T_world * kE) : make_isometry(100.0 + i, 0, 0, 0));
      t.keyframes.push_back(k);
      t.ground_truth.push_back({k.utime, k.T_world});
    }
  return t;
}

SessionLoop inter_loop(int query_index, bool correct, std::int32_t session = 1) {
  return {session, 0, session * kDay + 1000000 + query_index * 100000, correct};
}
}  // namespace

TEST_CASE("session metrics: a session 0.5 m / 2 deg off the map gives those numbers, counted from its first inter-session loop") {
  const TwoSessions t = two_sessions();
  // Inter-session loops 1->0 at keyframes 40 (correct) and 60 (wrong); loops within one session do not count.
  const std::vector<SessionLoop> loops = {
      inter_loop(60, false), inter_loop(40, true), {1, 1, kDay + 1000000 + 90 * 100000, true}, {0, 0, 5000000, true}};
  const SessionMetrics m = session_metrics(t.keyframes, loops, {{0, true}, {1, true}}, t.ground_truth);
  CHECK(m.sessions == 2);
  CHECK(m.sessions_aligned == 1);
  CHECK(m.sessions_unaligned == 0);
  CHECK(m.inter_session_loops_accepted == 2);
  CHECK(m.inter_session_loops_correct == 1);
  REQUIRE(m.alignment_error_m);
  REQUIRE(m.alignment_error_deg);
  CHECK(*m.alignment_error_m == Approx(0.5));
  CHECK(*m.alignment_error_deg == Approx(2.0));
  REQUIRE(m.per_session.size() == 2);
  CHECK(m.per_session[0].first);
  CHECK_FALSE(m.per_session[0].alignment_error_m);
  const SessionStats& s1 = m.per_session[1];
  CHECK(s1.keyframes == 100);
  CHECK(s1.anchor_utime == kDay + 1000000 + 40 * 100000);
  CHECK(s1.alignment_samples == 60);  // keyframes 40..99 (x = 10..69), all within 1 m of a session-0 keyframe
  // Mapped area from x = -9 (sqrt(81 + 1) < 10): steps ending at x = -9 .. 10 before the loop, 1 m each.
  REQUIRE(m.alignment_distance_m);
  CHECK(*m.alignment_distance_m == Approx(20.0));
  CHECK(s1.mapped_distance_m == Approx(79.0));  // x = -9 .. 69

  // Without the session list (older logs) a session counts as anchored once an inter-session loop was accepted.
  const SessionMetrics no_list = session_metrics(t.keyframes, loops, {}, t.ground_truth);
  CHECK(no_list.sessions_aligned == 1);
  CHECK(*no_list.alignment_error_m == Approx(0.5));
}

TEST_CASE("session metrics: an unanchored session is null and counted as unaligned") {
  const TwoSessions t = two_sessions(3);
  // Session 1 anchored (loop at keyframe 40); session 2 (same path, another day) never tied to the map.
  const SessionMetrics m = session_metrics(t.keyframes, {inter_loop(40, true)}, {{0, true}, {1, true}, {2, false}}, t.ground_truth);
  CHECK(m.sessions == 3);
  CHECK(m.sessions_aligned == 1);
  CHECK(m.sessions_unaligned == 1);
  REQUIRE(m.per_session.size() == 3);
  const SessionStats& s2 = m.per_session[2];
  CHECK_FALSE(s2.anchored);
  CHECK_FALSE(s2.alignment_error_m);
  CHECK_FALSE(s2.alignment_error_deg);
  CHECK_FALSE(s2.distance_to_alignment_m);
  CHECK(s2.mapped_distance_m > 90.0);          // its whole path lies near session 0's or session 1's keyframes
  CHECK(*m.alignment_error_m == Approx(0.5));  // the worst is over the sessions that have one

  // Only an unanchored later session: every worst figure is null.
  TwoSessions one = two_sessions();
  const SessionMetrics u = session_metrics(one.keyframes, {}, {{0, true}, {1, false}}, one.ground_truth);
  CHECK(u.sessions_unaligned == 1);
  CHECK(u.sessions_aligned == 0);
  CHECK_FALSE(u.alignment_error_m);
  CHECK_FALSE(u.alignment_error_deg);
  CHECK_FALSE(u.alignment_distance_m);

  // A single session (every drive before sessions): nothing after the first, nothing to judge.
  one.keyframes.resize(100);
  const SessionMetrics single = session_metrics(one.keyframes, {}, {}, one.ground_truth);
  CHECK(single.sessions == 1);
  CHECK(single.sessions_aligned + single.sessions_unaligned == 0);
  CHECK_FALSE(single.alignment_error_m);
}

TEST_CASE("evaluate: inter-session loops counted under the closure rule, sessions from the corrected keyframes") {
  const TwoSessions t = two_sessions();
  EvalInput in;
  for (const auto& k : t.keyframes) {
    in.ground_truth.push_back({k.utime, k.T_world});
    in.odometry.push_back({k.utime, k.T_world});
    in.scan_utimes.push_back(k.utime);
    KeyframePose kp;
    kp.utime = k.utime;
    kp.T_map_sensor = k.T_map;
    kp.session = k.session;
    in.corrected.push_back(kp);
  }
  in.sessions = {{0, true}, {1, true}};
  // Session-1 keyframe 40 (x = 10, y = 1) against session-0 keyframe 10: one exact loop, one 1 m off (wrong), and
  // one rejected (not counted).
  for (const auto& [qi, mi, off, status] : {std::tuple{40, 10, 0.0, LoopStatus::kAccepted}, std::tuple{50, 20, 1.0, LoopStatus::kAccepted},
                                            std::tuple{60, 30, 0.0, LoopStatus::kRejected}}) {
    LoopDecision r;
    r.event_id = static_cast<std::int64_t>(in.loops.size());
    r.query_utime = t.keyframes[static_cast<std::size_t>(100 + qi)].utime;
    r.match_utime = t.keyframes[static_cast<std::size_t>(mi)].utime;
    r.query.session = 1;
    r.match.session = 0;
    r.status = status;
    r.stage = status == LoopStatus::kAccepted ? "accepted" : "gicp";
    r.T_match_query = t.keyframes[static_cast<std::size_t>(mi)].T_world.inverse() * t.keyframes[static_cast<std::size_t>(100 + qi)].T_world;
    r.T_match_query.translation().y() += off;
    in.loops.push_back(r);
  }
  const EvalReport rep = evaluate(in, EvalConfig{});
  REQUIRE(rep.ok);
  CHECK(rep.closure.accepted == 2);
  CHECK(rep.closure.correct == 1);
  CHECK(rep.sessions.inter_session_loops_accepted == 2);
  CHECK(rep.sessions.inter_session_loops_correct == 1);
  CHECK(rep.sessions.sessions == 2);
  REQUIRE(rep.sessions.alignment_error_m);
  CHECK(*rep.sessions.alignment_error_m == Approx(0.5));
  CHECK(*rep.sessions.alignment_distance_m == Approx(20.0));
}
