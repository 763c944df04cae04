// The loop detector on a simulated VLP-16 drive that goes round a block and comes back to its start: loops are
// found only where it comes back, every accepted one is right, each decision is reported before its correction runs,
// and the correction brings the keyframes closer to the ground truth.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>

#include "loopd/pipeline/keyframe_selector.hpp"
#include "loopd/pipeline/loop_detector.hpp"
#include "loopd/sim/drive.hpp"

using namespace loopd;

namespace {
double rotation_deg(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI; }

double mean_position_error(const std::vector<Eigen::Isometry3d>& poses, const std::vector<Eigen::Isometry3d>& truth) {
  // Both start at the first keyframe's ground truth (the odometry does), so no alignment is needed.
  double sum = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) sum += (poses[i].translation() - truth[i].translation()).norm();
  return sum / static_cast<double>(poses.size());
}
}  // namespace

TEST_CASE("loop detector: a block lap and a revisit give correct loops, reported before their correction") {
  DriveConfig dc;
  dc.sensor = "vlp16";
  dc.route = "block";
  dc.num_scans = 340;  // round the block and on past the start (parked cars moved on the second visit)
  dc.seed = 23;
  // Scans with every sensor effect, and with every one but motion skew. loopd does not deskew yet: skew (up to
  // speed / rate = 1 m at the sweep's seam, more in turns) costs a few loops up to ~0.2 m / 1 deg (measured 0.206 m,
  // 1.06 deg on this drive); without it every accepted loop is within 0.2 m / 1 deg.
  const bool skew = GENERATE(true, false);
  dc.effects.motion_skew = skew;
  const double max_error_m = skew ? 0.3 : 0.2, max_error_deg = skew ? 1.5 : 1.0;
  CAPTURE(skew);
  const Drive drive = make_drive(dc);
  REQUIRE(drive.error.empty());

  LoopDetectorConfig cfg;
  cfg.sensor = "vlp16";
  LoopDetector detector(cfg);
  KeyframeSelector selector(cfg.keyframe);
  std::vector<Eigen::Isometry3d> truth, odometry;
  std::vector<double> route;  // [m] per keyframe
  std::vector<LoopDecision> reported, returned;
  std::map<std::int64_t, int> verified_per_query;
  std::optional<CorrectionOutput> last;
  int corrections = 0, reported_before_correction = 0, accepted = 0;
  std::int64_t id = 0;
  for (const DriveScan& s : drive.scans) {
    if (!selector.accept(s.odometry.T_world_sensor, s.utime)) continue;
    KeyframeInput in;
    in.key = KeyframeKey{0, id++};
    in.utime = s.utime;
    in.T_odom_sensor = s.odometry.T_world_sensor;
    in.residual = s.odometry.residual;
    in.motion_compensated = !skew;  // instantaneous scans: their steps are measured by the scans; skewed ones keep the odometry's
    auto features = std::make_shared<const KeyframeFeatures>(detector.compute_features(drive.simulate(s.index, 2)));
    REQUIRE(features->ok);
    truth.push_back(s.T_world_sensor);
    route.push_back(s.route_distance);
    odometry.push_back(s.odometry.T_world_sensor);
    const DetectorOutput out = detector.add_keyframe(in, features, [&](const LoopDecision& d) {
      reported.push_back(d);
      // The loop event can go out before the pose graph runs: the corrector holds the loops before this one only.
      if (d.status == LoopStatus::kAccepted && detector.corrector_state().num_loops == accepted) ++reported_before_correction;
    });
    for (const LoopDecision& d : out.decisions) {
      returned.push_back(d);
      INFO("keyframe " << d.query.index << " -> " << d.match.index << ": " << d.stage << " (" << d.reason << ")");
      CHECK(d.query == in.key);
      CHECK(d.query.index - d.match.index >= cfg.gate.min_index_gap);
      if (d.retrieval == "gate") {
        CHECK(d.gate_distance <= d.gate_radius);
        CHECK(d.place_distance == -1.0);
      } else {
        // Global retrieval: any keyframe far enough back along the drive, by its place descriptor.
        CHECK(d.retrieval == "global");
        CHECK(route[static_cast<std::size_t>(d.query.index)] - route[static_cast<std::size_t>(d.match.index)] >= 0.9 * cfg.retrieval.min_travel_gap);
        CHECK(d.place_distance <= cfg.retrieval.retrieval.max_place_distance);
      }
      if (d.stage != "descriptor" && d.retrieval == "gate") {
        ++verified_per_query[d.query.index];
        CHECK(d.descriptor_distance <= cfg.max_descriptor_distance);
      }
      if (d.status != LoopStatus::kAccepted) continue;
      ++accepted;
      const Eigen::Isometry3d gt = truth[static_cast<std::size_t>(d.match.index)].inverse() * truth[static_cast<std::size_t>(d.query.index)];
      const Eigen::Isometry3d err = gt.inverse() * d.T_match_query;
      CHECK(err.translation().norm() < max_error_m);
      CHECK(rotation_deg(err) < max_error_deg);
      // A real revisit: the same place after going round the block (once the map is corrected, guided GICP looks for
      // candidates 8 m around the corrected pose; a correct loop to a keyframe 6.2 m away is accepted on this drive).
      CHECK(gt.translation().norm() < 10.0);
      CHECK(route[static_cast<std::size_t>(d.query.index)] - route[static_cast<std::size_t>(d.match.index)] > 150.0);
    }
    if (out.correction) {
      ++corrections;
      REQUIRE(!out.decisions.empty());
      CHECK(out.decisions.back().status == LoopStatus::kAccepted);
      CHECK(out.correction->loop_event_id == out.decisions.back().event_id);
      CHECK(out.correction->T_map_sensor.size() == static_cast<std::size_t>(in.key.index + 1));
      last = out.correction;
    }
  }
  INFO("keyframes " << id << ", decisions " << returned.size() << ", accepted " << accepted);
  REQUIRE(returned.size() == reported.size());
  for (std::size_t i = 0; i < returned.size(); ++i) CHECK(returned[i].event_id == reported[i].event_id);
  for (const auto& [q, n] : verified_per_query) CHECK(n <= cfg.max_candidates_per_keyframe);
  CHECK(accepted >= 10);  // the revisit is over 100 m: dozens of keyframes
  CHECK(corrections == accepted);
  CHECK(reported_before_correction == accepted);
  CHECK(detector.bytes_per_keyframe() <= 150u * 1024u);
  REQUIRE(last);
  const double before = mean_position_error(odometry, truth);
  std::vector<Eigen::Isometry3d> corrected = last->T_map_sensor;
  // Keyframes after the last loop follow odometry in the corrected frame.
  for (std::size_t i = corrected.size(); i < odometry.size(); ++i) corrected.push_back(last->T_map_odom * odometry[i]);
  const double after = mean_position_error(corrected, truth);
  INFO("mean keyframe position error: odometry " << before << " m, corrected " << after << " m, steps measured " << detector.steps_measured());
  CHECK(after < 0.8 * before);
  // Skewed scans are never registered for a step; instantaneous ones nearly all are (148 of 156 measured), and their
  // steps take the corrected error down with them (0.11 m measured; 0.49 m with the odometry's steps).
  if (skew) CHECK(detector.steps_measured() == 0);
  if (!skew) {
    CHECK(detector.steps_measured() >= 0.9 * static_cast<double>(id - 1));
    CHECK(after < 0.2);
  }
}
