#include "loop_event_convert.hpp"

#include "loopd/base/pose.hpp"

namespace loopd {

loop_event_t to_message(const LoopDecision& d, std::int64_t utime) {
  loop_event_t m{};
  m.utime = utime;
  m.event_id = d.event_id;
  m.query_id = d.query.index;
  m.query_utime = d.query_utime;
  m.match_id = d.match.index;
  m.match_utime = d.match_utime;
  m.status = status_code(d.status);
  m.stage = d.stage;
  m.reason = d.reason;
  m.gate_distance = d.gate_distance;
  m.gate_radius = d.gate_radius;
  m.descriptor_distance = d.descriptor_distance;
  m.lcp_fraction = d.lcp_fraction;
  m.icp_residual = d.icp_residual;
  m.icp_fitness = d.icp_fitness;
  m.hungarian_consistency = d.hungarian_consistency;
  m.degeneracy = d.degeneracy;
  to_row_major(d.T_match_query, m.T_match_query);
  m.ms_descriptor = d.ms_descriptor;
  m.ms_fourpcs = d.ms_fourpcs;
  m.ms_gicp = d.ms_gicp;
  m.ms_hungarian = d.ms_hungarian;
  m.ms_total = d.ms_total;
  m.query_session = d.query.session;
  m.match_session = d.match.session;
  m.retrieval = d.retrieval;
  m.place_distance = d.place_distance;
  return m;
}

bool from_message(const loop_event_t& m, LoopDecision* d, std::string* error) {
  if (!loop_status_from_code(m.status, &d->status)) {
    if (error) *error = "loop event " + std::to_string(m.event_id) + ": unknown status " + std::to_string(int{m.status});
    return false;
  }
  d->event_id = m.event_id;
  d->query = KeyframeKey{m.query_session, m.query_id};
  d->match = KeyframeKey{m.match_session, m.match_id};
  d->query_utime = m.query_utime;
  d->match_utime = m.match_utime;
  d->stage = m.stage;
  d->reason = m.reason;
  d->gate_distance = m.gate_distance;
  d->gate_radius = m.gate_radius;
  d->descriptor_distance = m.descriptor_distance;
  d->lcp_fraction = m.lcp_fraction;
  d->icp_residual = m.icp_residual;
  d->icp_fitness = m.icp_fitness;
  d->hungarian_consistency = m.hungarian_consistency;
  d->degeneracy = m.degeneracy;
  d->T_match_query = from_row_major(m.T_match_query);
  d->ms_descriptor = m.ms_descriptor;
  d->ms_fourpcs = m.ms_fourpcs;
  d->ms_gicp = m.ms_gicp;
  d->ms_hungarian = m.ms_hungarian;
  d->ms_total = m.ms_total;
  d->retrieval = m.retrieval;
  d->place_distance = m.place_distance;
  d->information = Information6d::Zero();
  d->confirmed = false;
  d->published = true;
  return true;
}

}  // namespace loopd
