// The fleet's joint correction: sessions of several vehicles, each in its own odometry frame, placed in one map by
// the loops between them; a session no loop reaches is left unanchored.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <random>

#include "loopd/fleet/joint_correction.hpp"

using namespace loopd;

namespace {

Eigen::Isometry3d pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

/// Ground truth on a 40 m circle, keyframe i at angle start + i * 6 deg (heading along the circle).
Eigen::Isometry3d on_circle(double start, int i) {
  const double a = start + i * M_PI / 30.0;
  return pose(40.0 * std::cos(a), 40.0 * std::sin(a), a + M_PI / 2.0);
}

/// A session's keyframes: odometry = T_odom_world * truth, with a small drift per step.
std::vector<JointKeyframe> drive(SessionId session, double start, int n, const Eigen::Isometry3d& T_odom_world, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<JointKeyframe> out;
  Eigen::Isometry3d T_odom = T_odom_world * on_circle(start, 0);
  for (int i = 0; i < n; ++i) {
    if (i > 0) T_odom = T_odom * on_circle(start, i - 1).inverse() * on_circle(start, i) * pose(noise(rng), noise(rng), 0.0005);
    out.push_back({{session, i}, 1000 * i, T_odom, 0.05});
  }
  return out;
}

JointLoop loop(const KeyframeKey& q, const Eigen::Isometry3d& T_world_q, const KeyframeKey& m, const Eigen::Isometry3d& T_world_m) {
  JointLoop l;
  l.query = q;
  l.match = m;
  l.T_match_query = T_world_m.inverse() * T_world_q;
  l.information = Information6d::Identity() * 1e4;
  l.robust = false;
  return l;
}

}  // namespace

TEST_CASE("joint correction: two vehicles' sessions are aligned by the loops between them, an unreached one is not anchored") {
  std::mt19937 rng(7);
  // Vehicle 1 (the map) starts at angle 0 in the world frame; vehicle 2 starts at 90 deg, its odometry frame at its
  // own start; vehicle 3 drives elsewhere with no loop.
  std::vector<JointKeyframe> keyframes = drive(1000000, 0.0, 60, Eigen::Isometry3d::Identity(), rng);
  const Eigen::Isometry3d T_world_odom2 = on_circle(M_PI / 2.0, 0);
  const std::vector<JointKeyframe> second = drive(2000000, M_PI / 2.0, 40, T_world_odom2.inverse(), rng);
  const std::vector<JointKeyframe> third = drive(3000000, 0.0, 10, pose(500.0, 0.0, 1.0), rng);
  keyframes.insert(keyframes.end(), second.rbegin(), second.rend());  // any order
  keyframes.insert(keyframes.end(), third.begin(), third.end());
  // A vehicle that has just started: one keyframe, no loop (two segment starts follow each other in the chain).
  keyframes.push_back({{1500000, 0}, 0, pose(-300.0, 20.0, 0.3), 0.0});
  // Vehicle 2's keyframe j lies where vehicle 1's keyframe j + 15 does (15 x 6 deg = 90 deg).
  std::vector<JointLoop> loops;
  for (int j = 5; j < 40; j += 7) loops.push_back(loop({2000000, j}, on_circle(M_PI / 2.0, j), {1000000, j + 15}, on_circle(0.0, j + 15)));
  // ... and one found by vehicle 1 against vehicle 2's keyframe (the query's session chained first).
  loops.push_back(loop({1000000, 52}, on_circle(0.0, 52), {2000000, 37}, on_circle(M_PI / 2.0, 37)));
  loops.push_back(loop({1000000, 59}, on_circle(0.0, 59), {1000000, 0}, on_circle(0.0, 0)));  // vehicle 1 closes its lap
  loops.push_back(loop({2000000, 3}, on_circle(0.0, 0), {4000000, 0}, on_circle(0.0, 0)));    // names no stored keyframe

  JointCorrectionConfig config;
  const JointCorrection solved = solve_joint_correction(keyframes, loops, config);
  REQUIRE(solved.ok);
  CHECK(solved.loops_used == 7);
  CHECK(solved.loops_skipped == 1);
  REQUIRE(solved.keys.size() == 111);
  CHECK(solved.keys.front() == KeyframeKey{1000000, 0});
  REQUIRE(solved.sessions.size() == 4);
  CHECK(solved.sessions[0].anchored);
  CHECK_FALSE(solved.sessions[1].anchored);  // 1500000
  CHECK(solved.sessions[2].anchored);
  CHECK_FALSE(solved.sessions[3].anchored);
  CHECK(solved.sessions[2].num_keyframes == 40);

  // Where the two vehicles drove the same place, the joint map puts them as the truth does (what a shared map is for):
  // every keyframe j of vehicle 2 against keyframe j + 15 of vehicle 1, at the loops and between them.
  std::map<KeyframeKey, Eigen::Isometry3d> T_map;
  for (std::size_t i = 0; i < solved.keys.size(); ++i) T_map[solved.keys[i]] = solved.T_map_sensor[i];
  double worst_m = 0.0, worst_deg = 0.0;
  for (int j = 5; j < 40; ++j) {
    const Eigen::Isometry3d T_m_q = T_map[{1000000, j + 15}].inverse() * T_map[{2000000, j}];
    const Eigen::Isometry3d truth = on_circle(0.0, j + 15).inverse() * on_circle(M_PI / 2.0, j);
    const Eigen::Isometry3d error = truth.inverse() * T_m_q;
    worst_m = std::max(worst_m, error.translation().norm());
    worst_deg = std::max(worst_deg, Eigen::AngleAxisd(error.linear()).angle() * 180.0 / M_PI);
  }
  CHECK(worst_m < 0.2);
  CHECK(worst_deg < 1.0);
  // Vehicle 1's lap is closed: its last keyframe sits by its first as the truth says.
  const Eigen::Isometry3d lap = (T_map[{1000000, 0}].inverse() * T_map[{1000000, 59}]).inverse() * (on_circle(0.0, 0).inverse() * on_circle(0.0, 59));
  CHECK(lap.translation().norm() < 0.05);
}

TEST_CASE("joint correction: no loops leaves every session where odometry put it, the first one the map") {
  std::mt19937 rng(3);
  const std::vector<JointKeyframe> keyframes = drive(5, 0.0, 20, Eigen::Isometry3d::Identity(), rng);
  const JointCorrection solved = solve_joint_correction(keyframes, {}, JointCorrectionConfig{});
  REQUIRE(solved.ok);
  REQUIRE(solved.T_map_sensor.size() == 20);
  for (std::size_t i = 0; i < 20; ++i) CHECK(solved.T_map_sensor[i].isApprox(keyframes[i].T_odom_sensor, 1e-9));
  REQUIRE(solved.sessions.size() == 1);
  CHECK(solved.sessions[0].anchored);
  CHECK_FALSE(solve_joint_correction({}, {}, JointCorrectionConfig{}).ok);
}
