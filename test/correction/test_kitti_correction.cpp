// Loop correction on the real KITTI 00 / 05 ground-truth trajectories with injected odometry drift and the true loops
// picked from ground truth (Vlaminck 2019, Sec. 5.3: < 1 m apart, > 100 frames apart). Skips when the data is absent.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/correction/loop_corrector.hpp"
#include "loopd/correction/pose_graph.hpp"
#include "loopd/base/trajectory_io.hpp"
#include "loopd/correction/trajectory_tools.hpp"
#include "support/data_dir.hpp"

using namespace loopd;

namespace {
constexpr double kDeg = M_PI / 180.0;

struct KittiCase {
  std::vector<Eigen::Isometry3d> gt;
  DriftedTrajectory odom;
  std::vector<LoopConstraint> loops;
};

KittiCase load_case(const std::string& path, std::uint64_t seed, double scale_bias) {
  KittiCase k;
  const TrajectoryFile f = read_trajectory(path, TrajectoryFormat::kKitti);
  REQUIRE(f.error.empty());
  k.gt = f.poses;
  DriftConfig drift;
  drift.up_axis = -Eigen::Vector3d::UnitY();  // KITTI poses are camera poses: y points down
  drift.heading_bias = 1e-4;                  // [rad/m] ~0.6 deg per 100 m
  drift.scale_bias = scale_bias;
  drift.heading_noise = 2e-4;
  drift.tilt_noise = 5e-5;
  drift.translation_noise = 0.005;
  drift.seed = seed;
  k.odom = inject_drift(k.gt, drift);
  k.loops = find_ground_truth_loops(k.gt, 1.0, 100, 150, 8);
  return k;
}

/// graph_vs_heuristic: also require the pose graph to be at least as good as the heuristic.
void run_sequence(const std::string& path, const char* name, double scale_bias, bool graph_vs_heuristic) {
  const KittiCase k = load_case(path, 7, scale_bias);
  REQUIRE(k.loops.size() >= 2);
  const TrajectoryError before = trajectory_error(k.odom.poses, k.gt);
  std::vector<std::pair<std::string, std::vector<Eigen::Isometry3d>>> results;
  for (CorrectionMethod m : {CorrectionMethod::kHeuristic, CorrectionMethod::kHeuristicThenGraph, CorrectionMethod::kGraph}) {
    LoopCorrectorConfig cfg;
    cfg.method = m;
    LoopCorrector c(cfg);
    for (std::size_t i = 0; i < k.odom.poses.size(); ++i) c.add_keyframe(k.odom.poses[i], k.odom.residuals[i]);
    for (const auto& l : k.loops) REQUIRE(c.add_loop(l).ok);
    results.emplace_back(to_string(m), c.corrected_poses());
  }
  std::vector<TrajectoryError> errs;
  for (const auto& [method, poses] : results) {
    const TrajectoryError e = trajectory_error(poses, k.gt);
    errs.push_back(e);
    WARN(name << " scale bias " << scale_bias << " " << method << ": loops " << k.loops.size() << ", mean " << before.mean_closest << " -> "
              << e.mean_closest << " (x" << before.mean_closest / e.mean_closest << "), median " << before.median_closest << " -> "
              << e.median_closest << " (x" << before.median_closest / e.median_closest << "), ATE " << before.ate_rmse << " -> " << e.ate_rmse);
    CHECK(before.mean_closest / e.mean_closest >= 2.0);
    CHECK(before.median_closest / e.median_closest >= 2.0);
    double worst_t = 0, worst_r = 0;
    for (const auto& l : k.loops) {
      const auto [t, r] = loop_end_error(poses, l);
      worst_t = std::max(worst_t, t);
      worst_r = std::max(worst_r, r);
    }
    INFO(method << " worst loop end " << worst_t << " m " << worst_r / kDeg << " deg");
    CHECK(worst_t < 0.1);
    CHECK(worst_r < 0.5 * kDeg);
  }
  if (!graph_vs_heuristic) return;
  // Pose graph at least as good as the heuristic (ATE and closest-pose mean).
  CHECK(errs[1].ate_rmse <= errs[0].ate_rmse * 1.001);
  CHECK(errs[1].mean_closest <= errs[0].mean_closest * 1.001);
}
}  // namespace

TEST_CASE("KITTI 00 ground truth, heading bias + random walk: all methods halve the error, graph >= heuristic") {
  LOOPD_REQUIRE_DATA(path, "kitti/poses/00.txt");
  run_sequence(path, "KITTI 00", 0.0, true);
}

TEST_CASE("KITTI 05 ground truth, heading bias + random walk: all methods halve the error, graph >= heuristic") {
  LOOPD_REQUIRE_DATA(path, "kitti/poses/05.txt");
  run_sequence(path, "KITTI 05", 0.0, true);
}

// With a 1 % scale bias on top, the heuristic beats the graph on KITTI 00 (closest-pose mean 1.41 m vs 1.85 m; the
// white-noise odometry model cannot explain a systematic scale error), so only the 2x criterion is asserted here.
TEST_CASE("KITTI 00 and 05 ground truth, heading + 1% scale bias + random walk: all methods halve the error") {
  LOOPD_REQUIRE_DATA(path00, "kitti/poses/00.txt");
  run_sequence(path00, "KITTI 00", 0.01, false);
  LOOPD_REQUIRE_DATA(path05, "kitti/poses/05.txt");
  run_sequence(path05, "KITTI 05", 0.01, false);
}
