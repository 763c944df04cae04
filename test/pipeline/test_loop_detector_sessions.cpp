// Sessions at the library level (issue 31): a second drive through the same town on another day, in its own odometry
// frame and driven the other way, enters one LoopDetector after the first. Without any pose prior it is tied to the
// first by correct loops, its join is never bridged by a measured step, and its keyframes land where they belong.
#include <catch2/catch.hpp>
#include <algorithm>
#include <map>
#include <memory>
#include <vector>

#include "loopd/pipeline/keyframe_selector.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/sim/drive.hpp"

using namespace loopd;

namespace {

double rotation_deg(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI; }

Drive session_drive(int session) {
  DriveConfig dc;
  dc.sensor = "vlp16";
  dc.route = "block";
  dc.num_scans = 340;
  dc.seed = 23;
  dc.session = session;
  dc.effects.motion_skew = false;
  Drive drive = make_drive(dc);
  REQUIRE(drive.error.empty());
  return drive;
}

}  // namespace

TEST_CASE("loop detector: another day's drive in its own frame is tied to the first by correct loops and placed in its map") {
  LoopDetectorConfig config;
  config.sensor = "vlp16";
  LoopDetector detector(config);
  std::map<KeyframeKey, Eigen::Isometry3d> truth;  // ground truth in session 1's world frame (the map's)
  std::vector<LoopDecision> decisions;
  std::optional<CorrectionOutput> last;
  std::int64_t keyframes_of_second = 0;
  for (const int session : {1, 2}) {
    const Drive drive = session_drive(session);
    KeyframeSelector selector(config.keyframe);
    std::int64_t index = 0;
    for (const DriveScan& s : drive.scans) {
      if (!selector.accept(s.odometry.T_world_sensor, s.utime)) continue;
      KeyframeInput in;
      in.key = KeyframeKey{static_cast<SessionId>(session - 1), index++};
      in.utime = s.utime;
      in.T_odom_sensor = s.odometry.T_world_sensor;
      in.residual = s.odometry.residual;
      in.motion_compensated = true;  // instantaneous scans
      truth[in.key] = s.T_world_sensor;
      const auto features = std::make_shared<const KeyframeFeatures>(detector.compute_features(drive.simulate(s.index, 2)));
      REQUIRE(features->ok);
      const DetectorOutput out = detector.add_keyframe(in, features, [&](const LoopDecision& d) { decisions.push_back(d); });
      if (out.correction) last = out.correction;
    }
    if (session == 2) keyframes_of_second = index;
  }
  REQUIRE(keyframes_of_second > 50);

  // Loops from the second session to the first: found without a prior, every one right.
  int across = 0;
  for (const LoopDecision& d : decisions) {
    if (d.status != LoopStatus::kAccepted || d.query.session != 1 || d.match.session != 0) continue;
    ++across;
    const Eigen::Isometry3d gt = truth.at(d.match).inverse() * truth.at(d.query);
    const Eigen::Isometry3d err = gt.inverse() * d.T_match_query;
    INFO("loop " << d.query.index << " -> " << d.match.index << " (" << d.retrieval << "): " << err.translation().norm() << " m, "
                 << rotation_deg(err) << " deg");
    CHECK(err.translation().norm() < 0.3);
    CHECK(rotation_deg(err) < 1.5);
  }
  CHECK(across >= 3);

  // The second session is anchored, and the corrected map puts its keyframes where they were.
  const std::vector<SessionAlignment> sessions = detector.session_alignments();
  REQUIRE(sessions.size() == 2);
  CHECK(sessions[1].anchored);
  REQUIRE(last);
  std::vector<double> errors;
  for (std::size_t i = 0; i < last->keys.size(); ++i)
    if (last->keys[i].session == 1) errors.push_back((last->T_map_sensor[i].translation() - truth.at(last->keys[i]).translation()).norm());
  REQUIRE_FALSE(errors.empty());
  std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(errors.size() / 2), errors.end());
  INFO("median position error of the second session's keyframes in the map: " << errors[errors.size() / 2] << " m");
  CHECK(errors[errors.size() / 2] < 0.5);

  // Every step is measured but the first keyframe's of each session: the join carries no odometry, and no scan pair
  // bridges it either.
  CHECK(detector.steps_measured() <= static_cast<std::int64_t>(detector.num_keyframes()) - 2);
  CHECK(detector.steps_measured() >= static_cast<std::int64_t>(0.8 * static_cast<double>(detector.num_keyframes())));
}

TEST_CASE("loop detector: another vehicle's keyframes are candidates, its loops accepted once two agree, and link nothing here") {
  LoopDetectorConfig config;
  config.sensor = "vlp16";
  // Vehicle 1 maps the block; what it stores is what vehicle 2 reads from the shared map.
  LoopDetector first(config);
  std::vector<KeyframeRecord> stored;
  std::map<KeyframeKey, Eigen::Isometry3d> truth;
  const auto drive_into = [&](LoopDetector& detector, const Drive& drive, SessionId session, std::vector<LoopDecision>* decisions) {
    KeyframeSelector selector(config.keyframe);
    std::int64_t index = 0;
    for (const DriveScan& s : drive.scans) {
      if (!selector.accept(s.odometry.T_world_sensor, s.utime)) continue;
      KeyframeInput in;
      in.key = KeyframeKey{session, index++};
      in.utime = s.utime;
      in.T_odom_sensor = s.odometry.T_world_sensor;
      in.residual = s.odometry.residual;
      in.motion_compensated = true;
      truth[in.key] = s.T_world_sensor;
      const auto features = std::make_shared<const KeyframeFeatures>(detector.compute_features(drive.simulate(s.index, 2)));
      detector.add_keyframe(
          in, features,
          [&](const LoopDecision& d) {
            if (decisions) decisions->push_back(d);
          },
          [&](const KeyframeRecord& r, const Eigen::Isometry3d&) { stored.push_back(r); });
    }
  };
  drive_into(first, session_drive(1), 0, nullptr);
  const std::size_t first_keyframes = stored.size();
  REQUIRE(first_keyframes > 50);

  LoopDetector second(config);
  for (const KeyframeRecord& r : stored) CHECK(second.add_remote_keyframe(r));
  CHECK_FALSE(second.add_remote_keyframe(stored.front()));  // held already
  CHECK(second.remote_keyframes() == first_keyframes);
  std::vector<LoopDecision> decisions;
  drive_into(second, session_drive(2), 7, &decisions);

  int remote_accepted = 0;
  for (const LoopDecision& d : decisions) {
    if (d.status != LoopStatus::kAccepted || d.match.session != 0) continue;
    ++remote_accepted;
    const Eigen::Isometry3d gt = truth.at(d.match).inverse() * truth.at(d.query);
    const Eigen::Isometry3d err = gt.inverse() * d.T_match_query;
    INFO("remote loop " << d.query.index << " -> " << d.match.index << ": " << err.translation().norm() << " m, " << rotation_deg(err) << " deg");
    CHECK(err.translation().norm() < 0.3);
    CHECK(rotation_deg(err) < 1.5);
  }
  CHECK(remote_accepted >= 2);
  // The other vehicle's keyframes never join this detector's pose sequence: the joint correction places them.
  CHECK(second.num_keyframes() == stored.size() - first_keyframes);
}
