// loopd-map correct: the map's correction made again from what it holds: the detector is brought back from the map as
// loopd brings it back at start (poses, steps and decisions, no scans), the whole pose graph is solved once with every
// accepted loop the loop ledger leaves, and the result is stored through the map writer loopd uses, as a new revision
// (method "ledger"). Run it while no loopd writes to the map: a running loopd makes the same correction itself within
// map.ledger_poll of a ledger entry, and a starting one when its map's ledger is newer than the correction.
#include <algorithm>
#include <iostream>

#include "loopd/base/stopwatch.hpp"
#include "loopd/runtime/daemon_config.hpp"
#include "loopd/runtime/map_resume.hpp"
#include "loopd/runtime/map_writer.hpp"
#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

/// @brief Where the map writer passes what it stored: nowhere (the tool publishes nothing).
class StoredOnly final : public EngineSink {
 public:
  void on_decision(const LoopDecision&) override {}
  void on_correction(const CorrectionOutput&) override {}
};

/// @brief Keyframes a stop cut off before their decisions were stored (counted inside a transaction that is rolled
/// back: the map is left as it was). loopd removes them at start; the correction must not cover them.
StoreResult<std::int64_t> undecided_keyframes(MapStore& store) {
  StoreResult<std::int64_t> out;
  out.status = store.begin();
  if (!out.ok()) return out;
  out = store.drop_undecided();
  const StoreStatus undo = store.rollback();
  if (out.ok() && !undo.ok()) out.status = undo;
  return out;
}

}  // namespace

int run_correct(MapStore& store, const CorrectOptions& correct, const CommandOptions& options) {
  DaemonConfig config;
  std::string error;
  if (!correct.config.empty() && !load_config(correct.config, &config, &error)) {
    std::cerr << "loopd-map: " << error << "\n";
    return kExitBadInput;
  }
  config.engine.detector.m2dp.backend = Backend::kCpu;  // no descriptor is computed: no OpenCL device is opened
  const StoreResult<std::int64_t> undecided = undecided_keyframes(store);
  if (!undecided.ok() || undecided.value > 0) {
    std::cerr << "loopd-map: "
              << (undecided.ok() ? "map " + store.uri() + ": " + std::to_string(undecided.value) +
                                       " keyframe(s) wait for their decisions (loopd runs on the map, or a stop cut them off): let loopd "
                                       "correct it (it does within map.ledger_poll, or at its next start)"
                                 : undecided.status.message)
              << "\n";
    return kExitBadInput;
  }
  const StoreResult<std::optional<CorrectionRecord>> before = store.correction();
  if (!before.ok()) {
    std::cerr << "loopd-map: " << before.status.message << "\n";
    return kExitBadInput;
  }
  Stopwatch sw;
  LoopDetector detector(config.engine.detector);
  const ResumeSummary resumed = resume_detector(store, detector, KeyframeLoad::kPose);
  if (!resumed.ok) {
    std::cerr << "loopd-map: " << resumed.error << "\n";
    return kExitBadInput;
  }
  const double resume_s = sw.ms() * 1e-3;
  std::optional<CorrectionOutput> c;
  if (resumed.ledger_corrected)
    c = resumed.corrections.back();
  else
    c = detector.set_revoked_loops(revoked_loops(resumed.ledger), newest_seq(resumed.ledger), true);
  if (!c) {
    std::cout << "map " << store.uri() << ": no accepted loop, nothing to correct\n";
    if (options.json) print_json_line({{"corrected", false}, {"keyframes", resumed.keyframes}});
    return kExitOk;
  }
  StoredOnly nowhere;
  MapWriter writer(store, nowhere, 100);
  writer.on_correction(*c);
  if (!writer.flush(10.0) || writer.stats().failures > 0) {
    std::cerr << "loopd-map: map " << store.uri() << ": the correction was not stored: " << writer.stats().last_error << "\n";
    return kExitBadInput;
  }
  // How far the new correction moved each keyframe from the one it replaces.
  double moved_max = 0.0, moved_sum = 0.0;
  std::int64_t compared = 0;
  if (before.value) {
    std::map<KeyframeKey, Eigen::Vector3d> old_position;
    for (std::size_t i = 0; i < before.value->keys.size(); ++i)
      old_position.emplace(before.value->keys[i], before.value->T_map_sensor[i].translation());
    for (std::size_t i = 0; i < c->keys.size(); ++i) {
      const auto it = old_position.find(c->keys[i]);
      if (it == old_position.end()) continue;
      const double d = (c->T_map_sensor[i].translation() - it->second).norm();
      moved_max = std::max(moved_max, d);
      moved_sum += d;
      ++compared;
    }
  }
  const double moved_mean = compared > 0 ? moved_sum / static_cast<double>(compared) : 0.0;
  const std::int64_t loops = static_cast<std::int64_t>(c->resume_state.num_loops);
  Table table({"", "value"});
  table.add({"keyframes", std::to_string(c->keys.size())});
  table.add({"loops in the graph", std::to_string(loops)});
  table.add({"loops revoked (loop ledger)", std::to_string(detector.revoked_loops())});
  table.add({"correction revision", (before.value ? std::to_string(before.value->revision) : "none") + " -> " + std::to_string(c->revision)});
  table.add({"ledger entries honoured", std::to_string(c->ledger_seq)});
  table.add({"keyframes moved, mean / max [m]", fmt(moved_mean, 3) + " / " + fmt(moved_max, 3)});
  table.add({"read [s] / solve [ms]", fmt(resume_s, 2) + " / " + fmt(c->ms, 1)});
  std::cout << "map " << store.uri() << ": correction made again\n" << table.str();
  if (options.json)
    print_json_line({{"corrected", true},
                     {"keyframes", static_cast<std::int64_t>(c->keys.size())},
                     {"loops", loops},
                     {"loops_revoked", static_cast<std::int64_t>(detector.revoked_loops())},
                     {"previous_revision", before.value ? before.value->revision : 0},
                     {"revision", c->revision},
                     {"ledger_seq", c->ledger_seq},
                     {"moved_mean_m", moved_mean},
                     {"moved_max_m", moved_max},
                     {"read_s", resume_s},
                     {"solve_ms", c->ms}});
  return kExitOk;
}

}  // namespace loopd::tools
