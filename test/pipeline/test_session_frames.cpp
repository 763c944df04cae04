// Sessions in one pose sequence (SessionFrames) and the stricter test of loops without a pose prior
// (PriorFreeConfirmation).
#include <catch2/catch.hpp>

#include <cmath>

#include "loopd/pipeline/global_loops.hpp"
#include "loopd/pipeline/session_frames.hpp"

using namespace loopd;

namespace {
Eigen::Isometry3d pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}
}  // namespace

TEST_CASE("session frames: a new session is stitched on at zero motion, and only loops tie sessions together") {
  SessionFrames frames;
  // Session 0 drives 10 m along x: its frame is the continuous frame.
  for (int i = 0; i <= 5; ++i) {
    const SessionFrames::Placed p = frames.place({0, i}, pose(2.0 * i, 0.0, 0.0));
    CHECK_FALSE(p.starts_segment);
    CHECK(p.T_continuous_sensor.isApprox(pose(2.0 * i, 0.0, 0.0)));
  }
  // Session 1 starts at its own origin, turned: it continues where session 0's last keyframe lay.
  const SessionFrames::Placed first = frames.place({1, 0}, pose(0.0, 0.0, 0.0));
  CHECK(first.starts_segment);
  CHECK(first.T_continuous_sensor.isApprox(pose(10.0, 0.0, 0.0)));
  const SessionFrames::Placed next = frames.place({1, 1}, pose(0.0, 3.0, M_PI / 2));  // 3 m to its left, turned left
  CHECK_FALSE(next.starts_segment);
  CHECK(next.T_continuous_sensor.isApprox(pose(10.0, 3.0, M_PI / 2)));
  CHECK(frames.T_continuous_odom(1).isApprox(pose(10.0, 0.0, 0.0)));

  CHECK(frames.anchored(0));
  CHECK_FALSE(frames.anchored(1));
  CHECK_FALSE(frames.tied(0, 1));
  CHECK_FALSE(frames.cannot_tie(1, 0));
  frames.tie(1, 0);
  CHECK(frames.tied(0, 1));
  CHECK(frames.anchored(1));

  // Session 2 ties to session 1's group; a session already tied elsewhere cannot join another group.
  frames.place({2, 0}, Eigen::Isometry3d::Identity());
  frames.place({3, 0}, Eigen::Isometry3d::Identity());
  CHECK_FALSE(frames.cannot_tie(3, 2));
  frames.tie(3, 2);
  CHECK(frames.cannot_tie(3, 0).has_value());  // 3 would take 2 along
  CHECK_FALSE(frames.anchored(3));
  CHECK(frames.group(3) == 2);

  // The alignment of an anchored session at its newest keyframe: corrected pose times its odometry pose inverse.
  const std::vector<SessionAlignment> a = frames.alignments({{0, pose(10.0, 0.0, 0.0)}, {1, pose(50.0, 20.0, M_PI)}});
  REQUIRE(a.size() == 4);
  CHECK(a[1].anchored);
  CHECK(a[1].num_keyframes == 2);
  CHECK((a[1].T_map_session * pose(0.0, 3.0, M_PI / 2)).isApprox(pose(50.0, 20.0, M_PI)));
  CHECK_FALSE(a[2].anchored);
  CHECK(a[2].T_map_session.isApprox(Eigen::Isometry3d::Identity()));
}

TEST_CASE("prior-free confirmation: a loop links only when one of the next keyframes implies the same placement") {
  GlobalRetrievalConfig config;  // window 3, 0.5 m, 2 deg
  PriorFreeConfirmation c(config);
  auto loop = [](std::int64_t index, double dx, double yaw_deg) {
    PriorFreeLoop l;
    l.query = {1, index};
    l.match_group = 0;
    l.correction = pose(100.0 + dx, -40.0, (30.0 + yaw_deg) * M_PI / 180.0);
    l.p_map_query = Eigen::Vector3d(2.0 * static_cast<double>(index), 0.0, 0.0);
    l.event_id = index;
    return l;
  };
  CHECK_FALSE(c.confirm(loop(10, 0.0, 0.0)));         // held
  const auto agreed = c.confirm(loop(11, 0.2, 0.5));  // 0.2 m and 0.5 deg off, one keyframe later
  REQUIRE(agreed);
  CHECK(agreed->event_id == 10);
  CHECK_FALSE(c.confirm(loop(12, 0.0, 0.0)));  // the held one was let go: this one is held anew
  CHECK_FALSE(c.confirm(loop(13, 0.0, 3.0)));  // 3 deg off: disagrees, held instead
  CHECK_FALSE(c.confirm(loop(17, 0.0, 3.0)));  // 4 keyframes later: outside the window
  PriorFreeLoop other_group = loop(18, 0.0, 3.0);
  other_group.match_group = 4;
  CHECK_FALSE(c.confirm(other_group));  // another group of sessions: no agreement
  const auto [translation, rotation] = PriorFreeConfirmation::disagreement(loop(1, 0.0, 0.0), loop(2, 0.0, 2.0));
  CHECK(rotation == Approx(2.0).margin(1e-9));
  CHECK(translation > 0.0);
}
