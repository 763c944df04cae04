// Pose-graph correction (Ren 2019, Sec. 3.4) on synthetic drives with drift: accuracy vs the heuristic, robustness to
// a wrong loop, degenerate loops, plane constraints, reduced vs full graph.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <thread>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include "loopd/base/thread_priority.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/correction/pose_graph.hpp"
#include "loopd/correction/pose_graph_internal.hpp"
#include "loopd/correction/trajectory_tools.hpp"

using namespace loopd;

namespace {
constexpr double kDeg = M_PI / 180.0;

struct Scenario {
  std::vector<Eigen::Isometry3d> gt;
  DriftedTrajectory odom;
  std::vector<LoopConstraint> loops;
};

Scenario make_scenario(int n, std::uint64_t seed, double heading_bias = 0.0005) {
  Scenario s;
  s.gt = make_lap_trajectory(n);
  DriftConfig drift;
  drift.seed = seed;
  drift.heading_bias = heading_bias;
  drift.scale_bias = 0.0;
  s.odom = inject_drift(s.gt, drift);
  s.loops = find_ground_truth_loops(s.gt, 1.0, 100, 150, 0);
  return s;
}

std::vector<Eigen::Isometry3d> run(const Scenario& s, const std::vector<LoopConstraint>& loops, CorrectionMethod method,
                                   const PoseGraphConfig& graph = {}) {
  LoopCorrectorConfig cfg;
  cfg.method = method;
  cfg.graph = graph;
  LoopCorrector c(cfg);
  for (std::size_t i = 0; i < s.odom.poses.size(); ++i) c.add_keyframe(s.odom.poses[i], s.odom.residuals[i]);
  for (const auto& l : loops) REQUIRE(c.add_loop(l).ok);
  return c.corrected_poses();
}

double max_position_difference(const std::vector<Eigen::Isometry3d>& a, const std::vector<Eigen::Isometry3d>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i].translation() - b[i].translation()).norm());
  return m;
}
}  // namespace

TEST_CASE("graph: synthetic laps, error drops >= 2x, loop ends coincide, at least as good as the heuristic") {
  const Scenario s = make_scenario(2400, 11);
  REQUIRE(s.loops.size() >= 4);
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt);
  const auto heuristic = run(s, s.loops, CorrectionMethod::kHeuristic);
  const TrajectoryError eh = trajectory_error(heuristic, s.gt);
  for (CorrectionMethod m : {CorrectionMethod::kHeuristicThenGraph, CorrectionMethod::kGraph}) {
    const auto poses = run(s, s.loops, m);
    const TrajectoryError e = trajectory_error(poses, s.gt);
    INFO(to_string(m) << ": mean " << before.mean_closest << " -> " << e.mean_closest << " (heuristic " << eh.mean_closest << "), median "
                      << before.median_closest << " -> " << e.median_closest << ", ATE " << before.ate_rmse << " -> " << e.ate_rmse << " (heuristic "
                      << eh.ate_rmse << ")");
    CHECK(before.mean_closest / e.mean_closest >= 2.0);
    CHECK(before.median_closest / e.median_closest >= 2.0);
    CHECK(e.mean_closest <= eh.mean_closest * 1.001);
    CHECK(e.ate_rmse <= eh.ate_rmse * 1.001);
    for (const auto& l : s.loops) {
      const auto [t, r] = loop_end_error(poses, l);
      CHECK(t < 0.1);
      CHECK(r < 0.5 * kDeg);
    }
  }
}

TEST_CASE("graph: a wrong loop (5 m off) beside true loops moves the result by less than 0.5 m") {
  const Scenario s = make_scenario(2400, 12);
  REQUIRE(s.loops.size() >= 4);
  for (int offset : {10, 30, 60, 100}) {
    // The wrong loop joins keyframes `offset` frames after a true loop, with its transform shifted 5 m sideways.
    LoopConstraint bad;
    bad.query_index = s.loops[2].query_index + offset;
    bad.match_index = s.loops[2].match_index + offset;
    bad.T_match_query = Eigen::Translation3d(0.0, 5.0, 0.0) * (s.gt[bad.match_index].inverse() * s.gt[bad.query_index]);
    std::vector<LoopConstraint> with_bad = s.loops;
    with_bad.insert(with_bad.begin() + 3, bad);
    for (CorrectionMethod m : {CorrectionMethod::kHeuristicThenGraph, CorrectionMethod::kGraph}) {
      const double moved = max_position_difference(run(s, s.loops, m), run(s, with_bad, m));
      INFO(to_string(m) << ", offset " << offset << ": max pose shift from the wrong loop " << moved << " m");
      CHECK(moved < 0.5);
    }
  }
  LoopConstraint bad;
  bad.query_index = s.loops[2].query_index + 30;
  bad.match_index = s.loops[2].match_index + 30;
  bad.T_match_query = Eigen::Translation3d(0.0, 5.0, 0.0) * (s.gt[bad.match_index].inverse() * s.gt[bad.query_index]);
  std::vector<LoopConstraint> with_bad = s.loops;
  with_bad.insert(with_bad.begin() + 3, bad);
  // Without a robust kernel the same loop does bend the map (so the test above measures the kernel).
  PoseGraphConfig plain;
  plain.loop_loss = RobustLoss::kNone;
  const double moved_plain = max_position_difference(run(s, s.loops, CorrectionMethod::kHeuristicThenGraph, plain),
                                                     run(s, with_bad, CorrectionMethod::kHeuristicThenGraph, plain));
  INFO("no kernel: " << moved_plain << " m");
  CHECK(moved_plain > 1.0);
}

TEST_CASE("graph: zero-length loop ignored, same loop twice, loop to the first pose") {
  const Scenario s = make_scenario(900, 13);
  REQUIRE(!s.loops.empty());
  const LoopConstraint l = s.loops[0];
  const auto once = optimize_pose_graph(s.odom.poses, s.odom.residuals, {l}, {}, {});
  REQUIRE(once.poses.size() == s.odom.poses.size());
  LoopConstraint zero;
  zero.query_index = zero.match_index = 400;
  zero.T_match_query.translation() = Eigen::Vector3d(3, 0, 0);
  const auto with_zero = optimize_pose_graph(s.odom.poses, s.odom.residuals, {l, zero}, {}, {});
  CHECK(max_position_difference(once.poses, with_zero.poses) < 1e-6);
  const auto twice = optimize_pose_graph(s.odom.poses, s.odom.residuals, {l, l}, {}, {});
  // The same pair twice counts twice (double weight against odometry): a slightly different, still closed result.
  CHECK(max_position_difference(once.poses, twice.poses) < 0.5);
  for (const auto& r : {once, twice}) {
    const auto [t, a] = loop_end_error(r.poses, l);
    CHECK(t < 0.1);
    CHECK(a < 0.5 * kDeg);
  }
  // Loop to the very first pose (which is the fixed gauge node).
  LoopConstraint first;
  first.match_index = 0;
  first.query_index = l.query_index;
  first.T_match_query = s.gt[0].inverse() * s.gt[l.query_index];
  const auto r0 = optimize_pose_graph(s.odom.poses, s.odom.residuals, {first}, {}, {});
  CHECK(r0.poses[0].isApprox(s.odom.poses[0], 1e-9));
  const auto [t0, a0] = loop_end_error(r0.poses, first);
  CHECK(t0 < 0.1);
  CHECK(a0 < 0.5 * kDeg);
  // Empty and single-pose inputs are defined.
  CHECK(optimize_pose_graph({}, {}, {}, {}, {}).poses.empty());
  CHECK(optimize_pose_graph({Eigen::Isometry3d::Identity()}, {}, {l}, {}, {}).poses.size() == 1);
}

TEST_CASE("graph: chain-reduced solve matches the full graph") {
  const Scenario s = make_scenario(1500, 14);
  const auto warm = correct_heuristic_all(s.odom.poses, s.odom.residuals, s.loops, {});
  PoseGraphConfig full;
  full.reduce_chains = false;
  const auto a = optimize_pose_graph(s.odom.poses, s.odom.residuals, s.loops, warm, {});
  const auto b = optimize_pose_graph(s.odom.poses, s.odom.residuals, s.loops, warm, full);
  const TrajectoryError ea = trajectory_error(a.poses, s.gt), eb = trajectory_error(b.poses, s.gt);
  INFO("reduced " << ea.ate_rmse << " m (" << a.ms << " ms), full " << eb.ate_rmse << " m (" << b.ms << " ms)");
  CHECK(max_position_difference(a.poses, b.poses) < 0.5);
  CHECK(ea.ate_rmse <= eb.ate_rmse * 1.2 + 0.05);
}

TEST_CASE("graph: ground-plane constraints (Ren 2019, 3.4.2) pull roll, pitch and height back onto the plane") {
  // Flat drive, odometry with strong roll/pitch random walk; every 10th keyframe sees the ground 1.8 m below it.
  Scenario s;
  s.gt = make_lap_trajectory(1500);
  for (auto& T : s.gt) T.translation().z() = 0.0;
  DriftConfig drift;
  drift.seed = 15;
  drift.tilt_noise = 0.002;
  s.odom = inject_drift(s.gt, drift);
  s.loops = find_ground_truth_loops(s.gt, 1.0, 100, 150, 0);
  std::vector<PlaneObservation> planes;
  const Eigen::Vector3d n_w(0, 0, 1);
  const double d_w = 1.8;  // ground: z = -1.8
  for (std::size_t i = 0; i < s.gt.size(); i += 10) {
    PlaneObservation o;
    o.index = static_cast<int>(i);
    o.plane_sensor.head<3>() = s.gt[i].linear().transpose() * n_w;
    o.plane_sensor[3] = d_w + n_w.dot(s.gt[i].translation());
    planes.push_back(o);
  }
  const auto warm = correct_heuristic_all(s.odom.poses, s.odom.residuals, s.loops, {});
  PoseGraphConfig with_planes;
  with_planes.use_plane_constraints = true;
  const auto a = optimize_pose_graph(s.odom.poses, s.odom.residuals, s.loops, warm, {});
  const auto b = optimize_pose_graph(s.odom.poses, s.odom.residuals, s.loops, warm, with_planes, planes);
  auto height_rms = [&](const std::vector<Eigen::Isometry3d>& p) {
    double sum = 0;
    for (const auto& T : p) sum += T.translation().z() * T.translation().z();
    return std::sqrt(sum / static_cast<double>(p.size()));
  };
  auto tilt_rms = [&](const std::vector<Eigen::Isometry3d>& p) {
    double sum = 0;
    for (const auto& T : p) {
      const double c = std::clamp(T.linear().col(2).dot(Eigen::Vector3d::UnitZ()), -1.0, 1.0);
      sum += std::acos(c) * std::acos(c);
    }
    return std::sqrt(sum / static_cast<double>(p.size()));
  };
  INFO("height rms " << height_rms(a.poses) << " -> " << height_rms(b.poses) << " m, tilt rms " << tilt_rms(a.poses) / kDeg << " -> "
                     << tilt_rms(b.poses) / kDeg << " deg");
  REQUIRE(b.planes.size() == 1);
  CHECK(height_rms(b.poses) < 0.5 * height_rms(a.poses));
  CHECK(tilt_rms(b.poses) < 0.5 * tilt_rms(a.poses));
  CHECK(std::abs(b.planes[0][2]) > 0.999);
}

TEST_CASE("graph: odometry step information (covariance) decides where the loop error goes") {
  // Straight 300 m drive; the loop says pose 299 is 2 m left of where odometry put it.
  std::vector<Eigen::Isometry3d> odom;
  for (int i = 0; i < 300; ++i) odom.push_back(Eigen::Isometry3d(Eigen::Translation3d(i, 0, 0)));
  LoopConstraint loop;
  loop.match_index = 0;
  loop.query_index = 299;
  loop.T_match_query = Eigen::Translation3d(299, 2, 0) * Eigen::Isometry3d::Identity();
  // Stiff steps: 1 mm and 1e-5 rad (rotation must be stiff too, or small turns over the 300 m lever explain 2 m).
  Eigen::Matrix<double, 6, 6> stiff = Eigen::Matrix<double, 6, 6>::Identity() * 1e6, soft = Eigen::Matrix<double, 6, 6>::Identity();
  stiff.bottomRightCorner<3, 3>() *= 1e4;
  soft.bottomRightCorner<3, 3>() *= 1e10;  // only translation is uncertain on the soft steps
  LoopCorrectorConfig cfg;
  LoopCorrector c(cfg);
  for (int i = 0; i < 300; ++i) c.add_keyframe(odom[i], 0.0, (i >= 200 && i < 210) ? soft : stiff);
  REQUIRE(c.add_loop(loop).ok);
  const auto& p = c.corrected_poses();
  // Steps 200..209 take the 2 m sideways; before them nothing moves, after them everything is shifted.
  CHECK(std::abs(p[150].translation().y()) < 0.05);
  CHECK(p[250].translation().y() == Approx(2.0).margin(0.05));
  const auto [t, r] = loop_end_error(p, loop);
  CHECK(t < 0.1);
}

TEST_CASE("heuristic+graph online: the graph is re-solved at most once per max(graph_interval, 2% of the keyframes), at once when far off") {
  const Scenario s = make_scenario(900, 5);
  std::vector<LoopConstraint> loops = find_ground_truth_loops(s.gt, 1.0, 100, 1, 0);  // every revisiting pose
  std::sort(loops.begin(), loops.end(), [](const LoopConstraint& a, const LoopConstraint& b) {
    return std::max(a.query_index, a.match_index) < std::max(b.query_index, b.match_index);
  });
  REQUIRE(loops.size() >= 20);

  auto online = [&](int min_interval, double fraction, int* solved, int* deferred) {
    LoopCorrectorConfig cfg;
    cfg.graph_interval = min_interval;
    cfg.graph_interval_fraction = fraction;
    LoopCorrector c(cfg);
    std::size_t next = 0;
    int last_solved = -1;
    for (int i = 0; i < static_cast<int>(s.odom.poses.size()); ++i) {
      c.add_keyframe(s.odom.poses[static_cast<std::size_t>(i)], s.odom.residuals[static_cast<std::size_t>(i)]);
      for (; next < loops.size() && std::max(loops[next].query_index, loops[next].match_index) == i; ++next) {
        const std::vector<Eigen::Isometry3d> before_loop = c.corrected_poses();
        const CorrectionResult r = c.add_loop(loops[next]);
        REQUIRE(r.ok);
        // What the callers update after it (the gate): the poses before moved_from did not change, bit for bit.
        CHECK(r.moved_from == (r.graph_deferred ? std::min(loops[next].query_index, loops[next].match_index) + 1 : 0));
        for (PoseIndex k = 0; k < r.moved_from; ++k)
          REQUIRE(before_loop[static_cast<std::size_t>(k)].matrix() == c.corrected_poses()[static_cast<std::size_t>(k)].matrix());
        if (r.graph_deferred) CHECK(before_loop.back().matrix() != c.corrected_poses().back().matrix());
        const int interval = std::max(min_interval, static_cast<int>(fraction * (i + 1)));
        const bool far_off = r.start_translation_error > cfg.graph_now_translation || r.start_rotation_error > cfg.graph_now_rotation_deg * kDeg;
        INFO("loop ending at " << i << ": " << r.start_translation_error << " m off before, deferred " << r.graph_deferred);
        if (next == 0) CHECK(far_off);               // the first loop of the drive: odometry drift
        CHECK(r.graph_solved == !r.graph_deferred);  // what the daemon frees memory after
        if (r.graph_deferred) {
          ++*deferred;
          CHECK(i - last_solved < interval);
          CHECK_FALSE(far_off);
        } else {
          ++*solved;
          CHECK((last_solved < 0 || i - last_solved >= interval || far_off));
          last_solved = i;
        }
        CHECK(r.end_translation_error < 0.1);  // deferred or not, the new loop is closed
        CHECK(r.end_rotation_error < 0.5 * kDeg);
      }
    }
    return c.corrected_poses();
  };
  int solved = 0, deferred = 0, solved_every = 0, deferred_every = 0;
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt);
  const TrajectoryError every = trajectory_error(online(1, 0.0, &solved_every, &deferred_every), s.gt);
  const LoopCorrectorConfig defaults;
  const TrajectoryError spaced = trajectory_error(online(defaults.graph_interval, defaults.graph_interval_fraction, &solved, &deferred), s.gt);
  INFO("loops " << loops.size() << ": solved " << solved << ", deferred " << deferred << "; mean " << before.mean_closest << " -> "
                << spaced.mean_closest << " (graph on every loop " << every.mean_closest << ")");
  CHECK(deferred_every == 0);
  CHECK(solved_every == static_cast<int>(loops.size()));
  CHECK(deferred > 2 * solved);  // consecutive loops of a revisit mostly wait
  CHECK(before.mean_closest / spaced.mean_closest >= 2.0);
  CHECK(spaced.mean_closest <= every.mean_closest * 1.15);
}

TEST_CASE("graph: with a loop at every revisiting keyframe, the decimated graph matches the full graph") {
  const Scenario s = make_scenario(900, 5);
  const std::vector<LoopConstraint> loops = find_ground_truth_loops(s.gt, 1.0, 100, 1, 0);  // dense: every revisit
  REQUIRE(loops.size() * 2 >= 450);  // loop ends on half the keyframes or more: the chain reduction alone gives up
  const auto warm = correct_heuristic_all(s.odom.poses, s.odom.residuals, loops, {});
  PoseGraphConfig full;
  full.loop_end_stride = 1;
  const auto a = optimize_pose_graph(s.odom.poses, s.odom.residuals, loops, warm, {});
  const auto b = optimize_pose_graph(s.odom.poses, s.odom.residuals, loops, warm, full);
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt), ea = trajectory_error(a.poses, s.gt), eb = trajectory_error(b.poses, s.gt);
  INFO("loops " << loops.size() << "; mean " << before.mean_closest << " -> decimated " << ea.mean_closest << " m (" << a.ms << " ms), full "
                << eb.mean_closest << " m (" << b.ms << " ms)");
  CHECK(max_position_difference(a.poses, b.poses) < 0.15);
  CHECK(ea.mean_closest <= eb.mean_closest * 1.1 + 0.02);
  CHECK(ea.ate_rmse <= eb.ate_rmse * 1.1 + 0.02);
  for (const auto& l : loops) {  // loop ends still meet, through a few steps of odometry
    const auto [t, r] = loop_end_error(a.poses, l);
    CHECK(t < 0.15);
    CHECK(r < 0.5 * kDeg);
  }
}

TEST_CASE("max_nodes bounds the graph of a long drive, the coarser graph still closes every loop", "[pose_graph]") {
  const Scenario s = make_scenario(900, 5);
  const std::vector<LoopConstraint> loops = find_ground_truth_loops(s.gt, 1.0, 100, 1, 0);  // dense: every revisit
  const auto warm = correct_heuristic_all(s.odom.poses, s.odom.residuals, loops, {});
  PoseGraphConfig capped;
  capped.max_nodes = 200;  // every 5th keyframe: loop ends move up to 2 steps
  const detail::NodeLayout layout = detail::choose_nodes(s.gt.size(), detail::valid_loops(loops, s.gt.size()), {}, capped);
  CHECK(layout.anchors.size() <= 200);
  CHECK(layout.anchors.size() >= 180);
  CHECK(layout.anchors.back() == 899);
  PoseGraphConfig unbounded;
  unbounded.max_nodes = 0;
  CHECK(detail::choose_nodes(s.gt.size(), detail::valid_loops(loops, s.gt.size()), {}, unbounded).anchors.size() == 451);  // every 2nd + last

  const auto a = optimize_pose_graph(s.odom.poses, s.odom.residuals, loops, warm, capped);
  const auto b = optimize_pose_graph(s.odom.poses, s.odom.residuals, loops, warm, unbounded);
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt), ea = trajectory_error(a.poses, s.gt), eb = trajectory_error(b.poses, s.gt);
  INFO("loops " << loops.size() << "; mean " << before.mean_closest << " -> " << layout.anchors.size() << " nodes " << ea.mean_closest << " m ("
                << a.ms << " ms), 451 nodes " << eb.mean_closest << " m (" << b.ms << " ms); max difference "
                << max_position_difference(a.poses, b.poses) << " m");
  CHECK(ea.mean_closest < before.mean_closest / 5);
  CHECK(ea.mean_closest <= eb.mean_closest * 1.5 + 0.05);
  CHECK(max_position_difference(a.poses, b.poses) < 0.5);
  for (const auto& l : loops) {  // loop ends meet through at most 2 steps of odometry
    const auto [t, r] = loop_end_error(a.poses, l);
    CHECK(t < 0.3);
    CHECK(r < 1.0 * kDeg);
  }
}

TEST_CASE("segments: a second odometry segment moves rigidly onto its first loop, the first stays, later loops keep both") {
  auto yaw_pose = [](double x, double y, double yaw) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(x, y, 0.0);
    T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T;
  };
  // Truth: segment A drives 2 m steps east along y = 0; segment B (another session) drives 2 m steps west along y = 1,
  // its odometry in its own frame (origin at its start, heading west = its +x). B is stitched on where A ended.
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < 60; ++i) truth.push_back(yaw_pose(2.0 * i, 0.0, 0.0));
  for (int i = 0; i < 40; ++i) truth.push_back(yaw_pose(100.0 - 2.0 * i, 1.0, M_PI));
  for (const auto method : {CorrectionMethod::kHeuristicThenGraph, CorrectionMethod::kHeuristic, CorrectionMethod::kGraph}) {
    LoopCorrectorConfig config;
    config.method = method;
    LoopCorrector c(config);
    for (int i = 0; i < 60; ++i) c.add_keyframe(truth[static_cast<std::size_t>(i)], 0.03);
    const Eigen::Isometry3d stitch = truth[59];  // continuous <- B's odometry frame: zero motion across the join
    CHECK(c.add_segment_start(stitch) == 60);
    for (int i = 1; i < 40; ++i) c.add_keyframe(stitch * yaw_pose(2.0 * i, 0.0, 0.0), 0.03);
    REQUIRE(c.segment_starts() == std::vector<PoseIndex>{60});
    // B's keyframe 10 (x = 80) sees A's keyframe 40 (x = 80) 1 m to the side, turned around.
    LoopConstraint loop;
    loop.query_index = 70;
    loop.match_index = 40;
    loop.T_match_query = truth[40].inverse() * truth[70];
    INFO(to_string(method));
    REQUIRE(c.add_loop(loop).ok);
    const std::vector<Eigen::Isometry3d>& out = c.corrected_poses();
    double a_moved = 0.0, b_error = 0.0;
    for (std::size_t i = 0; i < 60; ++i) a_moved = std::max(a_moved, (out[i].translation() - truth[i].translation()).norm());
    for (std::size_t i = 60; i < 100; ++i) b_error = std::max(b_error, (out[i].translation() - truth[i].translation()).norm());
    CHECK(a_moved < 0.01);  // the join took the loop's error, not A's odometry
    CHECK(b_error < 0.05);  // B as a whole, rigidly, where it truly is
    // A second loop further on agrees: nothing moves by more than a centimetre.
    loop.query_index = 90;
    loop.match_index = 20;
    loop.T_match_query = truth[20].inverse() * truth[90];
    REQUIRE(c.add_loop(loop).ok);
    for (std::size_t i = 0; i < 100; ++i) CHECK((c.corrected_poses()[i].translation() - truth[i].translation()).norm() < 0.05);
  }
}

namespace {
/// The scenario's loops in the order they end, each with the keyframe it ends at.
std::vector<LoopConstraint> loops_by_end(const Scenario& s, int stride) {
  std::vector<LoopConstraint> loops = find_ground_truth_loops(s.gt, 1.0, 100, stride, 0);
  std::stable_sort(loops.begin(), loops.end(), [](const LoopConstraint& a, const LoopConstraint& b) {
    return std::max(a.query_index, a.match_index) < std::max(b.query_index, b.match_index);
  });
  return loops;
}

bool same_poses(const std::vector<Eigen::Isometry3d>& a, const std::vector<Eigen::Isometry3d>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!a[i].matrix().isApprox(b[i].matrix(), 0.0) && a[i].matrix() != b[i].matrix()) return false;
  return true;
}
}  // namespace

TEST_CASE(
    "heuristic+graph in the background: the solve is applied exactly max(graph_apply_after, graph_apply_fraction x the keyframes) later, equals the "
    "solve a caller "
    "would have waited "
    "for, and loses no loop") {
  const Scenario s = make_scenario(900, 5);
  const std::vector<LoopConstraint> loops = loops_by_end(s, 12);  // more than 10 keyframes apart
  REQUIRE(loops.size() >= 20);
  LoopCorrectorConfig cfg;
  cfg.graph_apply_after = 10;
  cfg.graph_apply_fraction = 0.02;  // so that the share, not the count, decides past 550 keyframes
  LoopCorrector c(cfg);
  std::size_t next = 0;
  int applied = 0, started_at = -1, longest_lag = 0;
  bool first_checked = false;
  for (int i = 0; i < static_cast<int>(s.odom.poses.size()); ++i) {
    const std::optional<CorrectionResult> a = c.apply_graph();
    if (a) {
      ++applied;
      INFO("applied before keyframe " << i << ", started after keyframe " << started_at);
      const int lag = std::max(cfg.graph_apply_after, static_cast<int>(cfg.graph_apply_fraction * (started_at + 1)));
      CHECK(i - (started_at + 1) == lag);
      longest_lag = std::max(longest_lag, lag);
      CHECK(a->graph_solved);
      CHECK(a->end_translation_error < 0.1);  // the loops since then are closed again on top of it
      if (!first_checked && !a->graph_deferred) {
        // No loop came in between: the first started_at + 1 poses are exactly what a caller that waited gets.
        LoopCorrector waited{LoopCorrectorConfig{}};
        for (int k = 0; k <= started_at; ++k)
          waited.add_keyframe(s.odom.poses[static_cast<std::size_t>(k)], s.odom.residuals[static_cast<std::size_t>(k)]);
        for (std::size_t l = 0; l < next; ++l) waited.add_loop(loops[l]);
        const std::vector<Eigen::Isometry3d> head(c.corrected_poses().begin(), c.corrected_poses().begin() + started_at + 1);
        CHECK(same_poses(head, waited.corrected_poses()));
        first_checked = true;
      }
      if (c.graph_pending()) started_at = i - 1;  // loops came while it ran: the next solve starts from here
    }
    c.add_keyframe(s.odom.poses[static_cast<std::size_t>(i)], s.odom.residuals[static_cast<std::size_t>(i)]);
    for (; next < loops.size() && std::max(loops[next].query_index, loops[next].match_index) == i; ++next) {
      const bool was_pending = c.graph_pending();
      const CorrectionResult r = c.add_loop(loops[next]);
      REQUIRE(r.ok);
      CHECK_FALSE(r.graph_solved);  // the caller never waits for a solve here
      CHECK(r.end_translation_error < 0.1);
      if (!was_pending && c.graph_pending()) started_at = i;
    }
  }
  CHECK(first_checked);
  CHECK(applied >= 3);
  CHECK(longest_lag > cfg.graph_apply_after);  // past 550 keyframes a solve is given 2 % of them
  // At the end everything is solved at once; as good as solving inside add_loop.
  LoopCorrector waited{LoopCorrectorConfig{}};
  for (std::size_t k = 0; k < s.odom.poses.size(); ++k) waited.add_keyframe(s.odom.poses[k], s.odom.residuals[k]);
  for (const LoopConstraint& l : loops) waited.add_loop(l);
  REQUIRE(c.solve_all().ok);
  REQUIRE(waited.solve_all().ok);
  CHECK_FALSE(c.graph_pending());
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt);
  const TrajectoryError background = trajectory_error(c.corrected_poses(), s.gt), inline_solve = trajectory_error(waited.corrected_poses(), s.gt);
  INFO("mean " << before.mean_closest << " -> " << background.mean_closest << " (solved inline " << inline_solve.mean_closest << ")");
  CHECK(before.mean_closest / background.mean_closest >= 2.0);
  CHECK(background.mean_closest <= inline_solve.mean_closest * 1.05 + 0.01);
}

TEST_CASE("the background solve's thread gives way: lower_this_thread_priority sets that thread's nice value only") {
#if defined(__linux__)
  const int before = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  int in_thread = -100;
  bool lowered = false;
  std::thread t([&] {
    lowered = lower_this_thread_priority(19);
    in_thread = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  });
  t.join();
  CHECK(lowered);
  CHECK(in_thread == 19);
  CHECK(getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))) == before);  // the caller keeps its own
  LoopCorrectorConfig bad;
  bad.graph_solve_nice = 20;
  CHECK(bad.validate());
#endif
}

TEST_CASE("heuristic+graph in the background: a corrector resumed while a solve was in flight goes on exactly as the one that never stopped") {
  const Scenario s = make_scenario(700, 9);
  const std::vector<LoopConstraint> loops = loops_by_end(s, 1);
  LoopCorrectorConfig cfg;
  cfg.graph_apply_after = 10;
  LoopCorrector a(cfg);
  std::optional<LoopCorrector> b;
  std::size_t next = 0;
  int resumed_at = -1, compared = 0;
  for (int i = 0; i < static_cast<int>(s.odom.poses.size()); ++i) {
    const auto ra = a.apply_graph();
    if (b) {
      const auto rb = b->apply_graph();
      CHECK(ra.has_value() == rb.has_value());
    }
    a.add_keyframe(s.odom.poses[static_cast<std::size_t>(i)], s.odom.residuals[static_cast<std::size_t>(i)]);
    if (b) b->add_keyframe(s.odom.poses[static_cast<std::size_t>(i)], s.odom.residuals[static_cast<std::size_t>(i)]);
    for (; next < loops.size() && std::max(loops[next].query_index, loops[next].match_index) == i; ++next) {
      REQUIRE(a.add_loop(loops[next]).ok);
      if (b) REQUIRE(b->add_loop(loops[next]).ok);
    }
    if (!b && a.graph_pending() && a.loops().size() >= 15) {
      // Stopped here: what a map store holds is the loops, the corrected poses and the state as bytes.
      const DecodedResumeState state = decode_resume_state(encode_resume_state(a.resume_state()));
      REQUIRE(state.ok);
      REQUIRE(state.state.pending);
      b.emplace(cfg);
      for (int k = 0; k <= i; ++k) b->add_keyframe(s.odom.poses[static_cast<std::size_t>(k)], s.odom.residuals[static_cast<std::size_t>(k)]);
      REQUIRE_FALSE(b->resume(a.loops(), a.corrected_poses(), state.state));
      CHECK(b->graph_pending());
      resumed_at = i;
    }
    if (b) {
      CHECK(same_poses(a.corrected_poses(), b->corrected_poses()));
      ++compared;
    }
  }
  INFO("resumed after keyframe " << resumed_at);
  REQUIRE(resumed_at > 0);
  CHECK(compared > 100);
  REQUIRE(a.solve_all().ok);
  REQUIRE(b->solve_all().ok);
  CHECK(same_poses(a.corrected_poses(), b->corrected_poses()));
}

TEST_CASE("corrector state: the solve in flight round-trips as bytes, a version-1 state still reads, damaged bytes are refused") {
  CorrectorResumeState s;
  s.max_end_index = 40;
  s.last_graph_index = 40;
  s.num_loops = 3;
  s.closed_spans = {{2, 30}, {5, 40}};
  const std::vector<std::uint8_t> plain = encode_resume_state(s);
  CorrectorResumeState::Pending p;
  p.poses = 3;
  p.loops = 2;
  p.spans = 1;
  p.solve_again = true;
  p.warm = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d(Eigen::Translation3d(1.0 / 3.0, 2, 3)),
            Eigen::Isometry3d(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()))};
  s.pending = p;
  const std::vector<std::uint8_t> bytes = encode_resume_state(s);
  const DecodedResumeState d = decode_resume_state(bytes);
  REQUIRE(d.ok);
  REQUIRE(d.state.pending);
  CHECK(d.state.pending->poses == 3);
  CHECK(d.state.pending->loops == 2);
  CHECK(d.state.pending->spans == 1);
  CHECK(d.state.pending->solve_again);
  CHECK(same_poses(d.state.pending->warm, p.warm));  // bit for bit: a resumed solve starts where the first one did
  // Version 1 (before solves in flight): the same fields without the flag.
  std::vector<std::uint8_t> v1(plain.begin(), plain.end() - 8);
  v1[4] = 1;
  const DecodedResumeState old = decode_resume_state(v1);
  REQUIRE(old.ok);
  CHECK_FALSE(old.state.pending);
  CHECK(old.state.closed_spans.size() == 2);
  for (std::size_t cut = 1; cut < bytes.size(); cut += 7) {
    const DecodedResumeState t = decode_resume_state(std::vector<std::uint8_t>(bytes.begin(), bytes.end() - static_cast<std::ptrdiff_t>(cut)));
    CHECK_FALSE(t.ok);
    CHECK_FALSE(t.error.empty());
  }
  std::vector<std::uint8_t> nan = bytes;
  const double q = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(&nan[nan.size() - 8], &q, 8);
  CHECK_FALSE(decode_resume_state(nan).ok);
}

TEST_CASE("graph: a start with a non-finite pose is never handed to Ceres (it would abort the process): solved from the chain instead") {
  const Scenario s = make_scenario(900, 5);
  REQUIRE_FALSE(s.loops.empty());
  std::vector<Eigen::Isometry3d> start = s.odom.poses;
  start[200].matrix()(0, 3) = std::numeric_limits<double>::quiet_NaN();
  start[201].linear() = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const PoseGraphResult g = optimize_pose_graph(s.odom.poses, s.odom.residuals, s.loops, start, PoseGraphConfig{});
  REQUIRE(g.poses.size() == s.odom.poses.size());
  for (const Eigen::Isometry3d& T : g.poses) REQUIRE(T.matrix().allFinite());
  CHECK(g.message.find("not finite") != std::string::npos);
  const auto [t, r] = loop_end_error(g.poses, s.loops.front());
  CHECK(t < 0.1);  // and it did solve
  std::vector<Eigen::Isometry3d> chain = s.odom.poses;
  chain[10].matrix()(1, 3) = std::numeric_limits<double>::infinity();
  const PoseGraphResult refused = optimize_pose_graph(chain, s.odom.residuals, s.loops, {}, PoseGraphConfig{});
  CHECK(refused.message.find("not solved") != std::string::npos);
}
