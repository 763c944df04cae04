// Keyframe steps measured by the scans (LoopCorrector::add_keyframe with T_previous_this): an odometry whose every
// step is 3 % too long closes every lap, so no loop can see its error; the measured steps remove it.
#include <catch2/catch.hpp>
#include <cmath>

#include "loopd/correction/loop_corrector.hpp"
#include "loopd/correction/trajectory_tools.hpp"

using namespace loopd;

namespace {

/// Two laps of a 120 x 80 m rounded rectangle, 1 m steps: the odometry with a 3 % scale error and yaw noise, the true
/// loops of lap 2 onto lap 1.
struct Laps {
  std::vector<Eigen::Isometry3d> truth;
  DriftedTrajectory odometry;
  std::vector<LoopConstraint> loops;
};

Laps make_laps() {
  Laps s;
  s.truth = make_lap_trajectory(800, 1.0, 120.0, 80.0, 0.0);
  DriftConfig drift;
  drift.scale_bias = 0.03;
  drift.heading_bias = 0.0;
  drift.seed = 7;
  s.odometry = inject_drift(s.truth, drift);
  s.loops = find_ground_truth_loops(s.truth, 1.0, 100, 20);
  return s;
}

/// Largest position error of `poses` against the truth after placing both at the first pose.
double max_error(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Eigen::Isometry3d>& truth) {
  const Eigen::Isometry3d align = truth.front() * poses.front().inverse();
  double worst = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) worst = std::max(worst, ((align * poses[i]).translation() - truth[i].translation()).norm());
  return worst;
}

Information6d step_information() {
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(1.0 / (0.01 * 0.01)), Eigen::Vector3d::Constant(1.0 / (0.0005 * 0.0005));
  return d.asDiagonal();
}

}  // namespace

TEST_CASE("measured keyframe steps take the odometry's scale error out of the corrected trajectory, which loops alone cannot") {
  const Laps s = make_laps();
  REQUIRE(s.loops.size() > 10);
  LoopCorrectorConfig config;
  config.method = CorrectionMethod::kGraph;
  LoopCorrector by_odometry(config), by_steps(config);
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    by_odometry.add_keyframe(s.odometry.poses[i], s.odometry.residuals[i]);
    if (i == 0) {
      by_steps.add_keyframe(s.odometry.poses[i], s.odometry.residuals[i]);
    } else {
      by_steps.add_keyframe(s.odometry.poses[i], s.odometry.residuals[i], step_information(), s.truth[i - 1].inverse() * s.truth[i]);
    }
  }
  CHECK(by_steps.measured_steps() == static_cast<std::int64_t>(s.truth.size()) - 1);
  // Placed by the measured steps: the chain is the truth (up to the start), the odometry poses are kept as given.
  CHECK(max_error(by_steps.chain_poses(), s.truth) < 1e-6);
  CHECK(by_steps.odometry_poses().back().isApprox(s.odometry.poses.back()));
  REQUIRE(by_odometry.add_loops(s.loops).ok);
  REQUIRE(by_steps.add_loops(s.loops).ok);
  const double odometry_error = max_error(by_odometry.corrected_poses(), s.truth);
  const double steps_error = max_error(by_steps.corrected_poses(), s.truth);
  INFO("corrected max error: odometry steps " << odometry_error << " m, measured steps " << steps_error << " m");
  CHECK(odometry_error > 0.5);  // a scaled lap closes: the loops leave the 3 % (up to ~2 m on a 120 x 80 m lap)
  CHECK(steps_error < 0.01);
  // T_map_odom still maps the user's odometry frame: the newest odometry pose lands on the newest corrected pose.
  CHECK((by_steps.T_map_odom() * s.odometry.poses.back()).isApprox(by_steps.corrected_poses().back(), 1e-9));
}

TEST_CASE("without measured steps the chain is the odometry itself, bit for bit") {
  const Laps s = make_laps();
  LoopCorrector c;
  for (std::size_t i = 0; i < 50; ++i) c.add_keyframe(s.odometry.poses[i], s.odometry.residuals[i]);
  CHECK(&c.chain_poses() == &c.odometry_poses());
  CHECK(c.measured_steps() == 0);
  // A measured step later: the poses before it stay the odometry's, the later ones follow the measured step.
  const Eigen::Isometry3d step = s.truth[49].inverse() * s.truth[50];
  c.add_keyframe(s.odometry.poses[50], s.odometry.residuals[50], step_information(), step);
  c.add_keyframe(s.odometry.poses[51], s.odometry.residuals[51]);
  REQUIRE(c.chain_poses().size() == 52);
  for (std::size_t i = 0; i < 50; ++i) CHECK(c.chain_poses()[i].isApprox(s.odometry.poses[i], 1e-12));
  CHECK(c.chain_poses()[50].isApprox(s.odometry.poses[49] * step, 1e-12));
  CHECK(c.chain_poses()[51].isApprox(c.chain_poses()[50] * (s.odometry.poses[50].inverse() * s.odometry.poses[51]), 1e-12));
}
