#include "loopd/runtime/republish_filter.hpp"

namespace loopd {

void RepublishFilter::expect(const std::vector<LoopDecision>& published) {
  for (const LoopDecision& d : published) published_[d.event_id] = d;
}

void RepublishFilter::on_decision(const LoopDecision& decision) {
  const auto it = published_.find(decision.event_id);
  if (it != published_.end()) {
    const LoopDecision& before = it->second;
    const bool same = before.query_utime == decision.query_utime && before.match == decision.match && before.status == decision.status &&
                      before.T_match_query.isApprox(decision.T_match_query, 1e-9);
    published_.erase(it);
    if (same) {
      ++not_republished_;
      return;
    }
  }
  next_.on_decision(decision);
}

}  // namespace loopd
