#include "loopd/pipeline/candidate_ranking.hpp"

#include <algorithm>

#include "loopd/descriptor/m2dp.hpp"

namespace loopd {

std::vector<RankedCandidate> rank_by_descriptor(const std::vector<GateCandidate>& gated, const Eigen::VectorXf& query_descriptor,
                                                const KeyframeDatabase& keyframes) {
  std::vector<RankedCandidate> ranked;
  for (const GateCandidate& c : gated) {
    const KeyframeRecord* m = keyframes.find(c.key);
    if (!m || !m->features) continue;
    ranked.push_back({m, c.distance, descriptor_distance(query_descriptor, m->features->descriptor)});
  }
  std::sort(ranked.begin(), ranked.end(), [](const RankedCandidate& a, const RankedCandidate& b) {
    return a.descriptor_distance < b.descriptor_distance || (a.descriptor_distance == b.descriptor_distance && a.match->key < b.match->key);
  });
  return ranked;
}

std::size_t count_to_verify(const std::vector<RankedCandidate>& ranked, double max_descriptor_distance, int max_candidates) {
  std::size_t n = 0;
  while (n < ranked.size() && static_cast<int>(n) < max_candidates && ranked[n].descriptor_distance <= max_descriptor_distance) ++n;
  return n;
}

}  // namespace loopd
