// loopd-map loops: the loop decisions a map holds.
#include <iostream>
#include <set>

#include "map_commands.hpp"
#include "tool_output.hpp"

namespace loopd::tools {
namespace {

void add_row(Table& table, const LoopDecision& r, bool revoked) {
  const Eigen::Vector3d t = r.T_match_query.translation();
  table.add({std::to_string(r.event_id), to_string(r.query), to_string(r.match), revoked ? "revoked" : to_string(r.status), r.stage,
             score_cell(r.descriptor_distance), score_cell(r.lcp_fraction), score_cell(r.icp_residual), score_cell(r.icp_fitness),
             fmt(t.x(), 3) + " " + fmt(t.y(), 3) + " " + fmt(t.z(), 3)});
}

}  // namespace

std::string score_cell(double v) { return v < 0.0 ? "-" : fmt(v, 3); }

nlohmann::json loop_json(const LoopDecision& r) {
  const Eigen::Vector3d t = r.T_match_query.translation();
  return {{"event_id", r.event_id},
          {"query", to_string(r.query)},
          {"match", to_string(r.match)},
          {"query_utime", r.query_utime},
          {"match_utime", r.match_utime},
          {"status", to_string(r.status)},
          {"stage", r.stage},
          {"reason", r.reason},
          {"gate_distance", r.gate_distance},
          {"descriptor_distance", r.descriptor_distance},
          {"lcp_fraction", r.lcp_fraction},
          {"icp_residual", r.icp_residual},
          {"icp_fitness", r.icp_fitness},
          {"hungarian_consistency", r.hungarian_consistency},
          {"degeneracy", r.degeneracy},
          {"translation", {t.x(), t.y(), t.z()}}};
}

int run_loops(MapStore& store, const LoopsOptions& loops, const CommandOptions& options) {
  if (loops.suspect) return run_suspect_loops(store, loops.limit, options);
  const bool all = loops.all;
  Table table({"event", "query", "match", "status", "stage", "descriptor", "lcp", "icp residual [m]", "icp fitness", "T_match_query t [m]"});
  nlohmann::json list = nlohmann::json::array();
  std::int64_t accepted = 0, rejected = 0, revoked_count = 0;
  const StoreResult<std::vector<LoopLedgerEntry>> ledger = store.loop_ledger();
  if (!ledger.ok()) {
    std::cerr << "loopd-map: " << ledger.status.message << "\n";
    return kExitBadInput;
  }
  const std::set<std::int64_t> revoked = revoked_loops(ledger.value);
  const StoreStatus read = store.for_each_loop(!all, [&](LoopDecision&& r) {
    const bool is_revoked = r.accepted() && revoked.count(r.event_id) > 0;
    add_row(table, r, is_revoked);
    if (options.json) {
      nlohmann::json entry = loop_json(r);
      entry["revoked"] = is_revoked;
      list.push_back(std::move(entry));
    }
    ++(r.accepted() ? accepted : rejected);
    if (is_revoked) ++revoked_count;
  });
  if (!read.ok()) {
    std::cerr << "loopd-map: " << read.message << "\n";
    return kExitBadInput;
  }
  std::cout << table.str() << accepted << " accepted"
            << (revoked_count > 0 ? " (" + std::to_string(revoked_count) + " of them revoked)" : std::string())
            << (all ? ", " + std::to_string(rejected) + " rejected" : std::string()) << "\n";
  if (options.json) print_json_line({{"accepted", accepted}, {"rejected", rejected}, {"revoked", revoked_count}, {"all", all}, {"loops", list}});
  return kExitOk;
}

}  // namespace loopd::tools
