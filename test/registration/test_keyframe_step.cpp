// The step between two keyframes measured by their scans: two simulated HDL-64E scans of a town street 2.3 m and
// 4 deg apart, prepared as the detector prepares keyframes, registered from an odometry step 3 % too long and 0.5 deg
// off. The scans must give back the true step; a guess the scans cannot confirm is refused, never taken.
#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "loopd/base/pose.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/pipeline/prepare_scan.hpp"
#include "loopd/registration/keyframe_step.hpp"
#include "loopd/sim/lidar_sim.hpp"
#include "loopd/sim/town.hpp"

using namespace loopd;

namespace {

constexpr double kDeg = M_PI / 180.0;

struct TwoKeyframes {
  PreparedScan previous, current;
  Eigen::Isometry3d T_previous_current = Eigen::Isometry3d::Identity();
};

TwoKeyframes make_keyframes() {
  const Town town = make_town(1);
  const LidarModel model = lidar_model_hdl64();
  const Eigen::Isometry3d T_world_previous = street_pose(town, 0, 0, 0, 25.0);
  TwoKeyframes k;
  k.T_previous_current.translation() = Eigen::Vector3d(2.2, 0.4, 0.02);
  k.T_previous_current.linear() = Eigen::AngleAxisd(4.0 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const PrepareConfig prepare = LoopDetectorConfig{}.prepare;
  k.previous = prepare_scan(simulate_scan(town, model, T_world_previous, 1, 2), &model, prepare);
  k.current = prepare_scan(simulate_scan(town, model, T_world_previous * k.T_previous_current, 2, 2), &model, prepare);
  return k;
}

/// The odometry's step: 3 % too long, 0.5 deg of yaw and 4 cm sideways off.
Eigen::Isometry3d odometry_step(const Eigen::Isometry3d& truth) {
  Eigen::Isometry3d T = truth;
  T.translation() *= 1.03;
  Eigen::Isometry3d N = Eigen::Isometry3d::Identity();
  N.linear() = Eigen::AngleAxisd(0.5 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  N.translation() = Eigen::Vector3d(0.0, 0.04, 0.0);
  return T * N;
}

KeyframeStep measure(const TwoKeyframes& k, const Eigen::Isometry3d& guess, const KeyframeStepConfig& config = {}) {
  return measure_keyframe_step(k.previous.points, k.previous.unpacked_normals(), k.current.points, k.current.unpacked_normals(), guess, config);
}

}  // namespace

TEST_CASE("a keyframe step measured by the scans is the true step, with the registration's information") {
  const TwoKeyframes k = make_keyframes();
  REQUIRE(k.previous.points.size() > 1000);
  const Eigen::Isometry3d guess = odometry_step(k.T_previous_current);
  const KeyframeStep step = measure(k, guess);
  INFO(step.reason);
  REQUIRE(step.measured);
  const Eigen::Isometry3d error = k.T_previous_current.inverse() * step.T_previous_current;
  const Eigen::Isometry3d odometry_error = k.T_previous_current.inverse() * guess;
  INFO("measured: " << error.translation().norm() << " m, " << rotation_angle(error) / kDeg
                    << " deg; odometry: " << odometry_error.translation().norm() << " m, " << rotation_angle(odometry_error) / kDeg << " deg");
  CHECK(error.translation().norm() < 0.01);
  CHECK(rotation_angle(error) < 0.05 * kDeg);  // 0.026 measured, the odometry 0.5
  CHECK(step.fitness >= KeyframeStepConfig{}.min_fitness);
  // The information: symmetric, positive definite, its best translation direction at translation_sigma (1 cm).
  const Information6d I = step.information;
  CHECK(I.isApprox(I.transpose(), 1e-9));
  const Eigen::SelfAdjointEigenSolver<Information6d> all(I);
  CHECK(all.eigenvalues().minCoeff() > 0.0);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> translation(I.topLeftCorner<3, 3>());
  CHECK(translation.eigenvalues().maxCoeff() == Approx(1.0 / (0.01 * 0.01)).epsilon(1e-6));
  // A street: the along-track direction is the weakest, but still determined (condition <= max_degeneracy).
  CHECK(step.degeneracy >= 1.0);
  CHECK(step.degeneracy <= KeyframeStepConfig{}.max_degeneracy);
}

TEST_CASE("a keyframe step the scans cannot confirm is refused and the odometry's kept") {
  const TwoKeyframes k = make_keyframes();
  // The scans find the true step, 0.8 m from this guess: farther than max_translation_change (0.5 m).
  Eigen::Isometry3d far = k.T_previous_current;
  far.translation() += Eigen::Vector3d(0.8, 0.0, 0.0);
  const KeyframeStep disagree = measure(k, far);
  CHECK_FALSE(disagree.measured);
  CHECK(disagree.T_previous_current.isApprox(far));
  CHECK(disagree.information.isZero(0.0));
  CHECK_FALSE(disagree.reason.empty());
  // An empty scan (a blinded sensor): refused, no crash.
  const KeyframeStep empty = measure_keyframe_step(k.previous.points, {}, {}, {}, k.T_previous_current, KeyframeStepConfig{});
  CHECK_FALSE(empty.measured);
  // A fitness no registration reaches: refused.
  KeyframeStepConfig strict;
  strict.min_fitness = 1.0;
  CHECK_FALSE(measure(k, odometry_step(k.T_previous_current), strict).measured);
  KeyframeStepConfig bad;
  bad.translation_sigma = 0.0;
  CHECK(bad.validate());
  CHECK_FALSE(KeyframeStepConfig{}.validate());
}

TEST_CASE("with tilt_from_odometry the step's roll and pitch are the odometry's, its heading and translation the scans'") {
  const TwoKeyframes k = make_keyframes();
  // The odometry's step: 0.3 deg of pitch and 0.5 deg of yaw off, 3 % too long. The odometry frame is level.
  Eigen::Isometry3d guess = odometry_step(k.T_previous_current);
  guess.linear() = guess.linear() * Eigen::AngleAxisd(0.3 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d level = Eigen::Matrix3d::Identity();
  const KeyframeStep step = measure_keyframe_step(k.previous.points, k.previous.unpacked_normals(), k.current.points, k.current.unpacked_normals(),
                                                  guess, KeyframeStepConfig{}, &level);
  REQUIRE(step.measured);
  const Eigen::Vector3d ypr_truth = k.T_previous_current.linear().eulerAngles(2, 1, 0);
  const Eigen::Vector3d ypr_guess = guess.linear().eulerAngles(2, 1, 0);
  const Eigen::Vector3d ypr_step = step.T_previous_current.linear().eulerAngles(2, 1, 0);
  CHECK(std::abs(ypr_step[0] - ypr_truth[0]) < 0.05 * kDeg);  // heading: the scans'
  CHECK(std::abs(ypr_step[1] - ypr_guess[1]) < 0.01 * kDeg);  // pitch: the odometry's
  CHECK(std::abs(ypr_step[2] - ypr_guess[2]) < 0.01 * kDeg);  // roll: the odometry's
  CHECK((step.T_previous_current.translation() - k.T_previous_current.translation()).norm() < 0.01);
}
