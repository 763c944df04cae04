// Heuristic loop correction (Vlaminck 2019, Sec. 4.4) on synthetic drives with injected drift and their true loops.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "loopd/correction/loop_correction.hpp"
#include "loopd/correction/loop_corrector.hpp"
#include "loopd/correction/trajectory_tools.hpp"

using namespace loopd;

namespace {
constexpr double kDeg = M_PI / 180.0;

struct Scenario {
  std::vector<Eigen::Isometry3d> gt;
  DriftedTrajectory odom;
  std::vector<LoopConstraint> loops;
};

Scenario make_scenario(int n, int max_loops, std::uint64_t seed) {
  Scenario s;
  s.gt = make_lap_trajectory(n);
  DriftConfig drift;
  drift.seed = seed;
  s.odom = inject_drift(s.gt, drift);
  s.loops = find_ground_truth_loops(s.gt, 1.0, 100, 150, max_loops);
  return s;
}

void check_ends(const std::vector<Eigen::Isometry3d>& poses, const LoopConstraint& l) {
  const auto [t, r] = loop_end_error(poses, l);
  INFO("loop " << l.query_index << " -> " << l.match_index << ": " << t << " m, " << r / kDeg << " deg");
  CHECK(t < 0.1);
  CHECK(r < 0.5 * kDeg);
}
}  // namespace

TEST_CASE("heuristic: one loop closes exactly and halves the error of a drifted lap") {
  const Scenario s = make_scenario(900, 1, 1);
  REQUIRE(s.loops.size() == 1);
  const LoopConstraint& loop = s.loops[0];
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt);
  HeuristicCorrectionConfig cfg;
  const auto corrected = correct_heuristic(s.odom.poses, s.odom.residuals, loop, cfg);
  const TrajectoryError after = trajectory_error(corrected, s.gt);
  INFO("mean " << before.mean_closest << " -> " << after.mean_closest << ", median " << before.median_closest << " -> " << after.median_closest);
  CHECK(before.mean_closest / after.mean_closest >= 2.0);
  CHECK(before.median_closest / after.median_closest >= 2.0);
  check_ends(corrected, loop);
  // Poses before the loop start are untouched.
  for (int i = 0; i <= std::min(loop.query_index, loop.match_index); ++i) CHECK(corrected[i].isApprox(s.odom.poses[i], 1e-12));
}

TEST_CASE("heuristic: several laps, every loop end coincides, error drops >= 2x") {
  const Scenario s = make_scenario(2400, 0, 2);
  REQUIRE(s.loops.size() >= 4);
  const auto corrected = correct_heuristic_all(s.odom.poses, s.odom.residuals, s.loops, {});
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt), after = trajectory_error(corrected, s.gt);
  INFO("loops " << s.loops.size() << " mean " << before.mean_closest << " -> " << after.mean_closest << ", median " << before.median_closest << " -> "
                << after.median_closest << ", ATE " << before.ate_rmse << " -> " << after.ate_rmse);
  CHECK(before.mean_closest / after.mean_closest >= 2.0);
  CHECK(before.median_closest / after.median_closest >= 2.0);
  for (const auto& l : s.loops) check_ends(corrected, l);
}

TEST_CASE("heuristic: the measured loop transform is honoured, not assumed identity") {
  // Straight line, odometry drifts sideways; the loop says pose 200 sits 3 m ahead and rotated 10 deg from pose 0.
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i <= 200; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.1 * i, 0.002 * i, 0.0);
    poses.push_back(T);
  }
  LoopConstraint loop;
  loop.query_index = 200;
  loop.match_index = 0;
  loop.T_match_query = Eigen::Translation3d(3.0, 0.0, 0.0) * Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitZ());
  const auto c = correct_heuristic(poses, {}, loop, {});
  check_ends(c, loop);
  // Equal weights: the middle pose gets half of the correction (translation linear in the literal form of the paper).
  HeuristicCorrectionConfig literal;
  literal.rotate_positions = false;
  const auto l = correct_heuristic(poses, {}, loop, literal);
  check_ends(l, loop);
  const Eigen::Vector3d moved = l[100].translation() - poses[100].translation();
  const Eigen::Vector3d full = l[200].translation() - poses[200].translation();
  CHECK((moved - 0.5 * full).norm() < 1e-9);
  CHECK(Eigen::AngleAxisd(l[100].linear()).angle() == Approx(5 * kDeg).margin(1e-9));
  // Rotation of the middle pose is half of 10 deg (slerp).
  CHECK(Eigen::AngleAxisd(c[100].linear()).angle() == Approx(5 * kDeg).margin(1e-9));
}

TEST_CASE("heuristic: residuals steer the error to high-residual edges") {
  std::vector<Eigen::Isometry3d> poses(101, Eigen::Isometry3d::Identity());
  for (int i = 0; i <= 100; ++i) poses[i].translation() = Eigen::Vector3d(i, 0.01 * i, 0);
  std::vector<double> residuals(101, 0.0);
  for (int i = 51; i <= 100; ++i) residuals[i] = 1.0;  // only the second half was badly matched
  LoopConstraint loop;
  loop.query_index = 100;
  loop.match_index = 0;
  loop.T_match_query.translation() = Eigen::Vector3d(100, 0, 0);
  HeuristicCorrectionConfig cfg;
  cfg.min_weight_fraction = 0.0;
  const auto c = correct_heuristic(poses, residuals, loop, cfg);
  // First half has (almost) no share: pose 50 hardly moves; the full correction (1 m) sits at 100.
  CHECK((c[50].translation() - poses[50].translation()).norm() < 1e-6);
  CHECK(c[100].translation().y() == Approx(0.0).margin(1e-9));
  CHECK(c[75].translation().y() == Approx(0.75 - 0.5).margin(1e-6));
}

TEST_CASE("heuristic: all-zero residuals give equal weights, same as no residuals") {
  const Scenario s = make_scenario(900, 1, 3);
  const std::vector<double> zeros(s.odom.poses.size(), 0.0);
  const auto a = correct_heuristic(s.odom.poses, zeros, s.loops[0], {});
  const auto b = correct_heuristic(s.odom.poses, {}, s.loops[0], {});
  for (std::size_t i = 0; i < a.size(); ++i) REQUIRE(a[i].isApprox(b[i], 1e-12));
  check_ends(a, s.loops[0]);
}

TEST_CASE("heuristic: zero-length loop and out-of-range indices leave the poses unchanged") {
  const Scenario s = make_scenario(300, 0, 4);
  LoopConstraint loop;
  loop.query_index = loop.match_index = 120;
  loop.T_match_query.translation() = Eigen::Vector3d(1, 2, 3);
  std::vector<Eigen::Isometry3d> p = s.odom.poses;
  const auto r = apply_heuristic_correction(p, edge_weights(p, {}, {}), loop);
  CHECK_FALSE(r.applied);
  for (std::size_t i = 0; i < p.size(); ++i) REQUIRE(p[i].isApprox(s.odom.poses[i]));
  loop.query_index = 5000;
  CHECK_FALSE(apply_heuristic_correction(p, edge_weights(p, {}, {}), loop).applied);
}

TEST_CASE("heuristic: loop to the first pose, query before match, and the same loop twice") {
  const Scenario s = make_scenario(900, 1, 5);
  LoopConstraint loop = s.loops[0];
  // Force the match to pose 0 with the ground-truth relative transform.
  loop.match_index = 0;
  loop.T_match_query = s.gt[0].inverse() * s.gt[loop.query_index];
  auto once = correct_heuristic(s.odom.poses, s.odom.residuals, loop, {});
  check_ends(once, loop);
  CHECK(once[0].isApprox(s.odom.poses[0]));
  // Same pair again on the corrected poses: nothing left to correct.
  const auto twice = correct_heuristic(once, s.odom.residuals, loop, {});
  for (std::size_t i = 0; i < once.size(); ++i) REQUIRE((twice[i].translation() - once[i].translation()).norm() < 1e-6);
  // The swapped form (query earlier than match) describes the same loop.
  LoopConstraint swapped;
  swapped.query_index = 0;
  swapped.match_index = loop.query_index;
  swapped.T_match_query = loop.T_match_query.inverse();
  const auto sw = correct_heuristic(s.odom.poses, s.odom.residuals, swapped, {});
  for (std::size_t i = 0; i < once.size(); ++i) REQUIRE((sw[i].translation() - once[i].translation()).norm() < 1e-6);
}

TEST_CASE("heuristic: nested loops and a second loop over a corrected stretch keep earlier loops closed") {
  const Scenario s = make_scenario(2400, 0, 6);
  REQUIRE(s.loops.size() >= 3);
  // loops[1] runs over the stretch loops[0] already corrected; `outer` (GT-consistent, 200 -> 1000) contains loops[2].
  LoopConstraint outer;
  outer.match_index = 200;
  outer.query_index = 1000;
  outer.T_match_query = s.gt[200].inverse() * s.gt[1000];
  REQUIRE(s.loops[2].match_index > 200);
  REQUIRE(s.loops[2].query_index < 1000);
  const std::vector<LoopConstraint> loops{s.loops[0], s.loops[1], s.loops[2], outer};
  const auto c = correct_heuristic_all(s.odom.poses, s.odom.residuals, loops, {});
  for (const auto& l : loops) check_ends(c, l);
  const TrajectoryError before = trajectory_error(s.odom.poses, s.gt), after = trajectory_error(c, s.gt);
  CHECK(after.mean_closest < before.mean_closest);

  // The same through the online LoopCorrector, loop by loop.
  LoopCorrectorConfig cfg;
  cfg.method = CorrectionMethod::kHeuristic;
  LoopCorrector corrector(cfg);
  for (std::size_t i = 0; i < s.odom.poses.size(); ++i) corrector.add_keyframe(s.odom.poses[i], s.odom.residuals[i]);
  for (const auto& l : loops) REQUIRE(corrector.add_loop(l).ok);
  for (const auto& l : loops) check_ends(corrector.corrected_poses(), l);
}

TEST_CASE("heuristic with closed spans: the edges kept closed are exactly those inside some span, with weight 0.3") {
  // apply_heuristic_with_spans counts the spans over each edge with a difference array; here each edge is checked
  // span by span instead, and the corrected poses must be bit-identical.
  const Scenario s = make_scenario(600, 0, 11);
  const std::vector<double> base = edge_weights(s.odom.poses, s.odom.residuals, {});
  HeuristicCorrectionConfig config;
  config.closed_span_weight = 0.3;  // not 0: a wrongly marked edge changes the poses
  std::mt19937 rng(5);
  std::uniform_int_distribution<PoseIndex> index(0, 599);
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<ClosedSpan> spans;
    const int count = trial % 7 == 0 ? 0 : 1 + trial % 12;
    for (int k = 0; k < count; ++k) {
      const PoseIndex a = index(rng), b = index(rng);
      spans.emplace_back(std::min(a, b), std::max(a, b));  // some of length 0, some beside the loop, some overlapping
    }
    LoopConstraint loop;
    loop.match_index = index(rng) / 2;
    loop.query_index = 300 + index(rng) / 2;
    loop.T_match_query = s.gt[static_cast<std::size_t>(loop.match_index)].inverse() * s.gt[static_cast<std::size_t>(loop.query_index)];

    std::vector<double> w = base;
    const PoseIndex lo = loop.match_index, hi = loop.query_index;
    bool any_free = false;
    std::vector<bool> closed(w.size(), false);
    for (PoseIndex i = lo + 1; i <= hi; ++i)
      for (const ClosedSpan& span : spans)
        if (span.first < i && i <= span.second) closed[static_cast<std::size_t>(i)] = true;
    double free_total = 0.0;
    for (PoseIndex i = lo + 1; i <= hi; ++i)
      if (!closed[static_cast<std::size_t>(i)]) free_total += w[static_cast<std::size_t>(i)];
    any_free = free_total > 0.0;
    if (any_free && !spans.empty())
      for (PoseIndex i = lo + 1; i <= hi; ++i)
        if (closed[static_cast<std::size_t>(i)]) w[static_cast<std::size_t>(i)] *= config.closed_span_weight;
    std::vector<Eigen::Isometry3d> expected = s.odom.poses;
    REQUIRE(apply_heuristic_correction(expected, w, loop, config.rotate_positions).applied);

    std::vector<Eigen::Isometry3d> got = s.odom.poses;
    std::vector<ClosedSpan> got_spans = spans;
    REQUIRE(apply_heuristic_with_spans(got, base, loop, got_spans, config).applied);
    INFO("trial " << trial << ", " << spans.size() << " spans, loop " << lo << " -> " << hi);
    REQUIRE(got_spans.size() == spans.size() + 1);
    for (std::size_t i = 0; i < got.size(); ++i) REQUIRE(got[i].matrix() == expected[i].matrix());
  }
}

TEST_CASE("LoopCorrector: later odometry poses map into the corrected frame") {
  const Scenario s = make_scenario(900, 1, 7);
  LoopCorrectorConfig cfg;
  cfg.method = CorrectionMethod::kHeuristic;
  LoopCorrector corrector(cfg);
  const int q = s.loops[0].query_index;
  for (int i = 0; i <= q; ++i) corrector.add_keyframe(s.odom.poses[i], s.odom.residuals[i]);
  REQUIRE(corrector.add_loop(s.loops[0]).ok);
  CHECK_FALSE(corrector.add_loop(LoopConstraint{3, 3, Eigen::Isometry3d::Identity(), {}}).ok);
  const Eigen::Isometry3d T_map_odom = corrector.corrected_poses().back() * s.odom.poses[q].inverse();
  CHECK(corrector.T_map_odom().isApprox(T_map_odom));
  // Keyframes added afterwards continue rigidly from the corrected end, exactly like the batch heuristic.
  for (int i = q + 1; i < static_cast<int>(s.odom.poses.size()); ++i) corrector.add_keyframe(s.odom.poses[i], s.odom.residuals[i]);
  const auto batch = correct_heuristic(s.odom.poses, s.odom.residuals, s.loops[0], cfg.heuristic);
  for (std::size_t i = 0; i < batch.size(); ++i) REQUIRE((corrector.corrected_poses()[i].translation() - batch[i].translation()).norm() < 1e-6);
  CHECK(corrector.to_map(s.odom.poses.back()).isApprox(batch.back(), 1e-9));
  CHECK_THROWS(LoopCorrector(LoopCorrectorConfig{CorrectionMethod::kHeuristic, HeuristicCorrectionConfig{-1.0}, {}}));
}
