// loopd-map loops --suspect: the accepted loops that the stored correction fits worst. A loop's residual is how far its
// T_match_query lies from what the corrected poses say (T_map_match^-1 * T_map_query): near zero for a loop the graph
// agrees with, large for one it had to override (a wrong loop the robust kernel down-weighted) or that the correction
// never saw. The operator's first look when a map picture shows a doubled wall.
#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include "loopd/base/angles.hpp"
#include "loopd/base/pose.hpp"
#include "map_commands.hpp"
#include "map_poses.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

struct SuspectLoop {
  LoopDecision loop;
  double residual_m = 0.0;    ///< [m] translation of T_match_query^-1 * T_map_match^-1 * T_map_query
  double residual_deg = 0.0;  ///< [deg] its rotation
};

}  // namespace

int run_suspect_loops(MapStore& store, int limit, const CommandOptions& options) {
  KeyframePoses poses;
  if (const StoreStatus read = read_keyframe_poses(store, false, std::nullopt, options.progress, &poses); !read.ok()) {
    std::cerr << "loopd-map: " << read.message << "\n";
    return kExitBadInput;
  }
  std::map<KeyframeKey, Eigen::Isometry3d> T_map;
  for (const KeyframePose& p : poses.poses) T_map.emplace(p.key, p.T);
  const StoreResult<std::vector<LoopLedgerEntry>> ledger = store.loop_ledger();
  if (!ledger.ok()) {
    std::cerr << "loopd-map: " << ledger.status.message << "\n";
    return kExitBadInput;
  }
  const std::set<std::int64_t> revoked = revoked_loops(ledger.value);
  std::vector<SuspectLoop> loops;
  std::int64_t without_pose = 0, revoked_count = 0;
  const StoreStatus read = store.for_each_loop(true, [&](LoopDecision&& r) {
    if (revoked.count(r.event_id)) {
      ++revoked_count;  // dealt with: not in the correction
      return;
    }
    const auto q = T_map.find(r.query), m = T_map.find(r.match);
    if (q == T_map.end() || m == T_map.end()) {
      ++without_pose;  // check() reports such a map as damaged
      return;
    }
    const Eigen::Isometry3d E = r.T_match_query.inverse() * (m->second.inverse() * q->second);
    loops.push_back({std::move(r), E.translation().norm(), rotation_angle(E) / kRadPerDeg});
  });
  if (!read.ok()) {
    std::cerr << "loopd-map: " << read.message << "\n";
    return kExitBadInput;
  }
  std::stable_sort(loops.begin(), loops.end(), [](const SuspectLoop& a, const SuspectLoop& b) { return a.residual_m > b.residual_m; });
  const std::size_t shown = std::min(loops.size(), static_cast<std::size_t>(limit));
  Table table({"event", "query", "match", "residual [m]", "residual [deg]", "stage", "lcp", "icp residual [m]", "icp fitness"});
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t i = 0; i < shown; ++i) {
    const SuspectLoop& s = loops[i];
    const LoopDecision& r = s.loop;
    table.add({std::to_string(r.event_id), to_string(r.query), to_string(r.match), fmt(s.residual_m, 3), fmt(s.residual_deg, 2), r.stage,
               score_cell(r.lcp_fraction), score_cell(r.icp_residual), score_cell(r.icp_fitness)});
    nlohmann::json entry = loop_json(r);
    entry["residual_m"] = s.residual_m;
    entry["residual_deg"] = s.residual_deg;
    list.push_back(std::move(entry));
  }
  std::cout << table.str() << shown << " of " << loops.size() + static_cast<std::size_t>(without_pose)
            << " accepted loops, largest residual first, against correction revision " << poses.correction_revision
            << (poses.correction_revision == 0 ? " (none stored: odometry poses)" : "") << "\n";
  if (revoked_count > 0) std::cout << revoked_count << " revoked loops left out (loopd-map FILE ledger lists them)\n";
  if (without_pose > 0) std::cout << without_pose << " accepted loops name a keyframe the map does not hold (no residual; see check)\n";
  if (options.json)
    print_json_line({{"suspect", true},
                     {"accepted", static_cast<std::int64_t>(loops.size()) + without_pose + revoked_count},
                     {"revoked", revoked_count},
                     {"correction_revision", poses.correction_revision},
                     {"without_pose", without_pose},
                     {"loops", list}});
  return kExitOk;
}

}  // namespace loopd::tools
