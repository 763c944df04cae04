// TrajectoryPublisher (what each trajectory_t carries) and TrajectoryAssembly (how a consumer rebuilds the trajectory).
#include <catch2/catch.hpp>

#include <cmath>
#include <set>

#include "trajectory_assembly.hpp"
#include "trajectory_publisher.hpp"

using namespace loopd;

namespace {

constexpr std::int64_t kSecond = 1000000;

/// A correction of `n` keyframes 2 m apart along x, revision `revision`.
CorrectionOutput straight_line(int n, std::int64_t revision) {
  CorrectionOutput c;
  c.revision = revision;
  c.loop_event_id = 100 + revision;
  c.method = "heuristic";
  for (int i = 0; i < n; ++i) {
    c.keys.push_back(KeyframeKey{0, i});
    c.utimes.push_back(1000 + i);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(2.0 * i, 0.0, 0.0);
    c.T_map_sensor.push_back(T);
  }
  c.T_map_odom.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  return c;
}

std::set<std::int64_t> ids_of(const trajectory_t& m) {
  std::set<std::int64_t> ids;
  for (const auto& k : m.keyframes) ids.insert(k.id);
  return ids;
}

void turn_about_z(Eigen::Isometry3d* T, double deg) {
  T->linear() = T->linear() * Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

TEST_CASE("trajectory_t: the first revision is full, later ones carry only what moved, a snapshot every period") {
  TrajectoryPublisher publisher(TrajectoryPublisherConfig{});  // 0.01 m, 0.1 deg, 10 s
  CorrectionOutput c = straight_line(5, 1);
  trajectory_t m = publisher.make_message(c, 0);
  CHECK(m.full);
  CHECK(m.num_keyframes == 5);
  CHECK(m.total_keyframes == 5);
  CHECK(m.revision == 1);
  CHECK(m.T_map_odom[3] == 0.5);

  // Revision 2, 1 s later: keyframe 3 moved 2 cm, keyframe 4 5 mm, keyframe 1 turned 0.2 deg, keyframe 5 is new.
  c.revision = 2;
  c.T_map_sensor[3].translation().y() += 0.02;
  c.T_map_sensor[4].translation().y() += 0.005;
  turn_about_z(&c.T_map_sensor[1], 0.2);
  c.keys.push_back(KeyframeKey{0, 5});
  c.utimes.push_back(1005);
  c.T_map_sensor.push_back(Eigen::Isometry3d(Eigen::Translation3d(10.0, 0.0, 0.0)));
  c.T_map_odom.translation() = Eigen::Vector3d(0.7, 0.0, 0.0);
  m = publisher.make_message(c, 1 * kSecond);
  CHECK_FALSE(m.full);
  CHECK(ids_of(m) == std::set<std::int64_t>{1, 3, 5});
  CHECK(m.num_keyframes == 3);
  CHECK(m.total_keyframes == 6);
  CHECK(m.revision == 2);
  CHECK(m.T_map_odom[3] == 0.7);  // T_map_odom with every revision
  CHECK(m.keyframes[1].position[1] == 0.02);

  // Revision 3: keyframe 4 moves another 6 mm: 11 mm from the pose it was last published with, so it goes out now.
  c.revision = 3;
  c.T_map_sensor[4].translation().y() += 0.006;
  m = publisher.make_message(c, 2 * kSecond);
  CHECK_FALSE(m.full);
  CHECK(ids_of(m) == std::set<std::int64_t>{4});

  // Revision 4: nothing moved: an empty partial message (still the revision and T_map_odom).
  c.revision = 4;
  m = publisher.make_message(c, 9 * kSecond);
  CHECK_FALSE(m.full);
  CHECK(m.num_keyframes == 0);
  CHECK(m.total_keyframes == 6);

  // 10 s after the first snapshot: every keyframe again.
  c.revision = 5;
  m = publisher.make_message(c, 10 * kSecond);
  CHECK(m.full);
  CHECK(m.num_keyframes == 6);
  CHECK(publisher.stats().messages == 5);
  CHECK(publisher.stats().snapshots == 2);
  CHECK(publisher.stats().keyframes == 5 + 3 + 1 + 0 + 6);
}

TEST_CASE("trajectory_t: period 0 and thresholds 0 publish every keyframe with every revision (the old behaviour)") {
  TrajectoryPublisherConfig config;
  config.min_move = 0.0;
  config.min_turn_deg = 0.0;
  config.snapshot_period = 0.0;
  REQUIRE_FALSE(config.validate());
  TrajectoryPublisher publisher(config);
  for (int rev = 1; rev <= 3; ++rev) {
    const trajectory_t m = publisher.make_message(straight_line(4 + rev, rev), rev);
    CHECK(m.full);
    CHECK(m.num_keyframes == 4 + rev);
  }
  CHECK_FALSE(publisher.final_snapshot(10));  // the last message was full already
}

TEST_CASE("trajectory_t: a changed keyframe list or a clock that went back forces a snapshot, and the end snapshot is exact") {
  TrajectoryPublisher publisher(TrajectoryPublisherConfig{});
  CorrectionOutput c = straight_line(4, 1);
  REQUIRE(publisher.make_message(c, 100 * kSecond).full);
  c.revision = 2;
  CHECK_FALSE(publisher.make_message(c, 101 * kSecond).full);
  c.revision = 3;
  CHECK(publisher.make_message(c, 50 * kSecond).full);  // clock jumped back
  c.revision = 4;
  c.keys[2].session = 1;  // the keyframe list is no longer the one published
  CHECK(publisher.make_message(c, 51 * kSecond).full);
  c.revision = 5;
  c.T_map_sensor[0].translation().z() += 0.004;  // below the threshold: not published ...
  const trajectory_t partial = publisher.make_message(c, 52 * kSecond);
  CHECK(partial.num_keyframes == 0);
  const auto end = publisher.final_snapshot(53 * kSecond);  // ... but the end snapshot has the exact pose
  REQUIRE(end);
  CHECK(end->full);
  CHECK(end->revision == 5);
  CHECK(end->num_keyframes == 4);
  CHECK(end->keyframes[0].position[2] == 0.004);
  CHECK_FALSE(publisher.final_snapshot(54 * kSecond));
}

TEST_CASE("trajectory_t config: negative, infinite or NaN thresholds and periods are refused by name") {
  TrajectoryPublisherConfig c;
  CHECK_FALSE(c.validate());
  c.min_move = -0.1;
  CHECK(c.validate()->find("output.trajectory_min_move") == 0);
  c = {};
  c.min_move = INFINITY;
  CHECK(c.validate());
  c = {};
  c.min_turn_deg = NAN;
  CHECK(c.validate()->find("output.trajectory_min_turn_deg") == 0);
  c = {};
  c.snapshot_period = -1.0;
  CHECK(c.validate()->find("output.trajectory_snapshot_period") == 0);
}

TEST_CASE("TrajectoryAssembly rebuilds every pose within the thresholds from partial messages, exactly after a snapshot") {
  TrajectoryPublisher publisher(TrajectoryPublisherConfig{});
  TrajectoryAssembly assembly;
  CorrectionOutput c = straight_line(3, 0);
  // 40 revisions, 0.5 s apart: a keyframe per revision, and every keyframe drifts by a revision-dependent amount.
  for (int rev = 1; rev <= 40; ++rev) {
    c.revision = rev;
    for (std::size_t i = 0; i < c.T_map_sensor.size(); ++i) {
      c.T_map_sensor[i].translation().y() += 0.003 * static_cast<double>((i + static_cast<std::size_t>(rev)) % 5);
      turn_about_z(&c.T_map_sensor[i], 0.03 * static_cast<double>(i % 3));
    }
    const auto n = static_cast<std::int64_t>(c.keys.size());
    c.keys.push_back(KeyframeKey{0, n});
    c.utimes.push_back(1000 + n);
    c.T_map_sensor.push_back(Eigen::Isometry3d(Eigen::Translation3d(2.0 * static_cast<double>(n), 0.0, 0.0)));
    REQUIRE(assembly.apply(publisher.make_message(c, rev * kSecond / 2)));
    REQUIRE(assembly.complete());
    const trajectory_t t = assembly.current();
    REQUIRE(t.keyframes.size() == c.keys.size());
    for (std::size_t i = 0; i < c.keys.size(); ++i) {
      CHECK(t.keyframes[i].id == c.keys[i].index);
      const Eigen::Vector3d p(t.keyframes[i].position[0], t.keyframes[i].position[1], t.keyframes[i].position[2]);
      CHECK((p - c.T_map_sensor[i].translation()).norm() <= 0.01);
      const Eigen::Quaterniond q(t.keyframes[i].orientation[0], t.keyframes[i].orientation[1], t.keyframes[i].orientation[2],
                                 t.keyframes[i].orientation[3]);
      CHECK(q.angularDistance(Eigen::Quaterniond(c.T_map_sensor[i].linear())) * 180.0 / M_PI <= 0.1 + 1e-9);
    }
  }
  CHECK(assembly.snapshots() == 2);              // t = 0.5 s and 10.5 s
  CHECK(publisher.stats().keyframes < 40 * 23);  // fewer poses than every keyframe with every revision
  const auto end = publisher.final_snapshot(21 * kSecond);
  REQUIRE(end);
  REQUIRE(assembly.apply(*end));
  const trajectory_t t = assembly.current();
  for (std::size_t i = 0; i < c.keys.size(); ++i) CHECK(t.keyframes[i].position[1] == c.T_map_sensor[i].translation().y());
  CHECK(assembly.revision() == 40);
}

TEST_CASE("TrajectoryAssembly: an older revision is ignored, a partial message without a snapshot is incomplete") {
  trajectory_t full{};
  full.revision = 5;
  full.full = true;
  full.total_keyframes = 2;
  for (int i = 0; i < 2; ++i) {
    keyframe_pose_t k{};
    k.id = 10 + i;
    k.position[0] = i;
    k.orientation[0] = 1.0;
    full.keyframes.push_back(k);
  }
  full.num_keyframes = 2;

  TrajectoryAssembly a;
  trajectory_t partial{};
  partial.revision = 4;
  partial.total_keyframes = 1;
  keyframe_pose_t moved{};
  moved.id = 11;
  moved.position[0] = 7.0;
  partial.keyframes.push_back(moved);
  partial.num_keyframes = 1;
  REQUIRE(a.apply(partial));
  CHECK_FALSE(a.complete());  // no snapshot yet
  REQUIRE(a.apply(full));
  CHECK(a.complete());
  CHECK(a.current().keyframes[1].position[0] == 1.0);
  CHECK_FALSE(a.apply(partial));  // revision 4 < 5
  partial.revision = 6;
  partial.total_keyframes = 3;  // announces a keyframe this log never carried
  REQUIRE(a.apply(partial));
  CHECK(a.current().keyframes[1].position[0] == 7.0);
  CHECK(a.current().keyframes.size() == 2);
  CHECK_FALSE(a.complete());
  CHECK(a.messages() == 3);
}
