// LoopDetector: the loop ledger's revocations (an operator took an accepted loop back, or restored it).
#include "loopd/pipeline/loop_detector.hpp"

#include <map>

namespace loopd {

std::optional<CorrectionOutput> LoopDetector::set_revoked_loops(const std::set<std::int64_t>& event_ids, std::int64_t ledger_seq, bool force) {
  ledger_seq_ = ledger_seq;
  const std::vector<LoopConstraint>& held = corrector_.loops();
  // The graph's loops by event id: in the order they were accepted, whichever were taken out and put back.
  std::map<std::int64_t, LoopConstraint> kept;
  bool changed = false;
  for (std::size_t i = 0; i < held.size() && i < loop_events_.size(); ++i) {
    if (event_ids.count(loop_events_[i])) {
      revoked_[loop_events_[i]] = held[i];
      changed = true;
    } else {
      kept.emplace(loop_events_[i], held[i]);
    }
  }
  for (auto it = revoked_.begin(); it != revoked_.end();) {
    if (event_ids.count(it->first)) {
      ++it;
      continue;
    }
    kept.emplace(it->first, it->second);  // restored: joins the graph again
    it = revoked_.erase(it);
    changed = true;
  }
  if (!changed && !force) return std::nullopt;
  if (revision_ == 0 && kept.empty() && revoked_.empty()) return std::nullopt;  // no loop yet: nothing to correct
  std::vector<LoopConstraint> loops;
  std::vector<std::int64_t> events;
  loops.reserve(kept.size());
  events.reserve(kept.size());
  for (const auto& [event, loop] : kept) {
    events.push_back(event);
    loops.push_back(loop);
  }
  Stopwatch sw;
  const CorrectionResult result = corrector_.replace_loops(std::move(loops));
  if (!result.ok) return std::nullopt;  // every loop was taken by the corrector before: it takes them again
  loop_events_ = std::move(events);
  CorrectionOutput c = correction_output(result, last_correction_event_id_, sw);
  c.method = "ledger";  // the whole graph solved again without the revoked loops
  update_gate(0);
  return c;
}

}  // namespace loopd
