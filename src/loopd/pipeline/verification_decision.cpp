#include "loopd/pipeline/verification_decision.hpp"

namespace loopd {

void apply_verification(const VerifyResult& v, double ms_descriptor, LoopDecision& d) {
  d.stage = v.accepted ? "accepted" : to_string(v.stage);
  d.reason = v.reason;
  d.lcp_fraction = v.lcp_fraction;
  d.icp_residual = v.icp_residual;
  d.icp_fitness = v.icp_fitness;
  d.hungarian_consistency = v.hungarian_consistency;
  d.degeneracy = v.degeneracy;
  d.T_match_query = v.T_match_query;
  d.information = v.information;
  d.ms_descriptor = ms_descriptor;
  d.ms_fourpcs = v.ms_fourpcs;
  d.ms_gicp = v.ms_gicp;
  d.ms_hungarian = v.ms_hungarian;
  d.ms_total = v.ms_total + ms_descriptor;
  d.status = v.accepted ? LoopStatus::kAccepted : LoopStatus::kRejected;
}

LoopConstraint to_loop_constraint(const VerifyResult& v, PoseIndex query, PoseIndex match) {
  LoopConstraint loop;
  loop.query_index = query;
  loop.match_index = match;
  loop.T_match_query = v.T_match_query;
  loop.information = v.information;  // both in loopd's one order (base/information.hpp)
  return loop;
}

}  // namespace loopd
