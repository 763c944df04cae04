// Area-bounded maps through the engine and the map writer: a simulated VLP-16 drive round one block several times
// keeps at most a bounded number of keyframes per place; retired keyframes are never candidates again, the map frees
// their features and map clouds, the pose graph keeps every loop and every keyframe (a map reopened solves to the same
// trajectory), and the trajectory is as accurate as without retirement.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <set>

#include "loopd/runtime/loopd_engine.hpp"
#include "loopd/runtime/map_resume.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "loopd/sim/drive.hpp"
#include "support/block_revisit_drive.hpp"
#include "support/engine_replay.hpp"
#include "support/open_test_map.hpp"
#include "support/temp_dir.hpp"

using namespace loopd;

namespace {

EngineConfig drive_config(bool retire) {
  EngineConfig c = test::replay_config();
  c.retirement.enabled = retire;
  return c;
}

/// Before the map writer: the final correction (the whole graph solved once more at the end; not the map's).
struct FinalTap : ForwardingSink {
  using ForwardingSink::ForwardingSink;
  std::optional<CorrectionOutput> final_correction;
  void on_final_correction(const CorrectionOutput& c) override {
    final_correction = c;
    ForwardingSink::on_final_correction(c);
  }
};

/// After the map writer: what was retired when, and every decision against it.
struct Watcher : EngineSink {
  std::set<KeyframeKey> retired;
  std::vector<std::string> problems;
  std::int64_t accepted = 0;
  void on_decision(const LoopDecision& d) override {
    if (retired.count(d.match)) problems.push_back("decision " + std::to_string(d.event_id) + " names retired keyframe " + to_string(d.match));
    if (d.accepted()) ++accepted;
  }
  void on_correction(const CorrectionOutput&) override {}
  void on_keyframes_retired(const KeyframeKey& by, const std::vector<KeyframeKey>& keys) override {
    for (const KeyframeKey& k : keys) {
      if (!(k < by)) problems.push_back("keyframe " + to_string(by) + " retired a newer one, " + to_string(k));
      if (!retired.insert(k).second) problems.push_back("keyframe " + to_string(k) + " retired twice");
    }
  }
};

struct Run {
  Watcher watcher;
  std::optional<CorrectionOutput> final_correction;
  EngineStats stats;
  double ate = 0.0;
};

/// Replays the drive into a fresh map at `path`; the RMSE of the final trajectory's positions against the ground truth.
void replay(const Drive& drive, const std::string& path, bool retire, Run& run) {
  auto store = test::open_test_map(path);
  REQUIRE(store->put_session(SessionRecord{}).ok());
  MapWriter writer(*store, run.watcher, 100);
  FinalTap tap(writer);
  LoopdEngine engine(drive_config(retire), &tap);
  engine.make_map_clouds();
  REQUIRE(engine.resume(*store, false).ok);
  test::replay_drive(engine, drive);
  REQUIRE(writer.flush(5.0));
  CHECK(writer.stats().failures == 0);
  run.stats = engine.stats();
  REQUIRE(tap.final_correction);
  run.final_correction = tap.final_correction;
  const CorrectionOutput& c = *tap.final_correction;
  std::map<std::int64_t, Eigen::Vector3d> truth;
  for (const DriveScan& s : drive.scans) truth[s.utime] = s.T_world_sensor.translation();
  // The first session's odometry starts at the ground truth, so the map frame is the world frame: no alignment.
  double sum = 0.0;
  for (std::size_t i = 0; i < c.keys.size(); ++i) sum += (c.T_map_sensor[i].translation() - truth.at(c.utimes[i])).squaredNorm();
  run.ate = std::sqrt(sum / static_cast<double>(c.keys.size()));
}

double largest_move(const std::vector<Eigen::Isometry3d>& a, const std::vector<Eigen::Isometry3d>& b) {
  REQUIRE(a.size() == b.size());
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i].translation() - b[i].translation()).norm());
  return m;
}

}  // namespace

TEST_CASE("engine: retirement keeps a bounded number of keyframes per place, never a candidate again, and every loop in the graph") {
  const Drive drive = test::block_revisit_drive(560);  // a lap and two revisits
  test::TempDir dir;
  Run with, without;
  replay(drive, dir.file("retired.db"), true, with);
  replay(drive, dir.file("all.db"), false, without);
  INFO("retired " << with.stats.keyframes_retired << " of " << with.stats.keyframes << " keyframes; ATE " << with.ate << " m, without " << without.ate
                  << " m; loops " << with.watcher.accepted << " / " << without.watcher.accepted);
  for (const std::string& p : with.watcher.problems) FAIL_CHECK(p);
  CHECK(without.stats.keyframes_retired == 0);
  CHECK(with.stats.keyframes_retired == static_cast<std::int64_t>(with.watcher.retired.size()));
  CHECK(with.stats.keyframes_retired * 5 > with.stats.keyframes);  // the two revisits retire a good share
  CHECK(with.stats.keyframes == without.stats.keyframes);          // the same keyframes, the same trajectory length
  // As accurate, and still closing the revisits (retirement thins candidates; the newest views stay).
  CHECK(with.ate < without.ate + 0.05);
  CHECK(with.watcher.accepted * 10 > without.watcher.accepted * 7);

  // The map: the retired rows keep their poses, their features and map clouds are gone.
  auto store = test::open_test_map(dir.file("retired.db"));
  const StoreResult<MapStats> stats = store->stats();
  REQUIRE(stats.ok());
  CHECK(stats.value.keyframes == with.stats.keyframes);
  CHECK(stats.value.keyframes_retired == with.stats.keyframes_retired);
  CHECK(stats.value.map_clouds == stats.value.keyframes - stats.value.keyframes_retired);
  auto full = test::open_test_map(dir.file("all.db"));
  CHECK(stats.value.map_cloud_bytes < full->stats().value.map_cloud_bytes * 9 / 10);
  REQUIRE(store->check().ok());

  // The graph keeps every loop and keyframe: the map brought back into a detector solves, as a whole, to the run's
  // final trajectory.
  LoopDetector detector(drive_config(true).detector);
  const ResumeSummary resumed = resume_detector(*store, detector, KeyframeLoad::kFull, true);
  INFO(resumed.error);
  REQUIRE(resumed.ok);
  CHECK(resumed.keyframes_retired == with.stats.keyframes_retired);
  CHECK(detector.indexed_places() == static_cast<std::size_t>(with.stats.keyframes - with.stats.keyframes_retired));
  const std::optional<CorrectionOutput> solved = detector.set_revoked_loops({}, 0, true);
  REQUIRE(solved);
  CHECK(solved->resume_state.num_loops == with.final_correction->resume_state.num_loops);
  CHECK(solved->resume_state.num_loops == with.watcher.accepted);
  REQUIRE(solved->keys == with.final_correction->keys);
  const double moved = largest_move(solved->T_map_sensor, with.final_correction->T_map_sensor);
  INFO("the reopened map's solve differs from the run's by up to " << moved << " m");
  CHECK(moved < 1e-3);  // 6e-5 m measured
}
