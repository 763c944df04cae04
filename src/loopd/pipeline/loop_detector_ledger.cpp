// LoopDetector: the loop ledger's revocations (an operator took an accepted loop back, or restored it).
#include "loopd/pipeline/loop_detector.hpp"

#include <algorithm>

namespace loopd {

std::optional<CorrectionOutput> LoopDetector::set_revoked_loops(const std::set<std::int64_t>& event_ids, std::int64_t ledger_seq, bool force) {
  ledger_seq_ = ledger_seq;
  const std::vector<LoopConstraint>& held = corrector_.loops();
  std::vector<LoopConstraint> kept;
  std::vector<std::int64_t> kept_events;
  kept.reserve(held.size());
  kept_events.reserve(held.size());
  bool changed = false;
  for (std::size_t i = 0; i < held.size() && i < loop_events_.size(); ++i) {
    if (event_ids.count(loop_events_[i])) {
      revoked_[loop_events_[i]] = held[i];
      changed = true;
      continue;
    }
    kept.push_back(held[i]);
    kept_events.push_back(loop_events_[i]);
  }
  for (auto it = revoked_.begin(); it != revoked_.end();) {
    if (event_ids.count(it->first)) {
      ++it;
      continue;
    }
    kept.push_back(it->second);  // restored: joins the graph again
    kept_events.push_back(it->first);
    it = revoked_.erase(it);
    changed = true;
  }
  if (!changed && !force) return std::nullopt;
  if (revision_ == 0 && kept.empty() && revoked_.empty()) return std::nullopt;  // no loop yet: nothing to correct
  // In event order, the order they were accepted in: the graph is the same whichever loops were taken out and put back.
  std::vector<std::size_t> order(kept.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return kept_events[a] < kept_events[b]; });
  std::vector<LoopConstraint> loops;
  std::vector<std::int64_t> events;
  loops.reserve(order.size());
  events.reserve(order.size());
  for (std::size_t i : order) {
    loops.push_back(kept[i]);
    events.push_back(kept_events[i]);
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
