#include "map_records_convert.hpp"

#include "loopd/correction/loop_corrector.hpp"

namespace loopd {

LoopRecord to_loop_record(const LoopDecision& d) {
  LoopRecord r;
  r.event_id = d.event_id;
  r.query = d.query;
  r.match = d.match;
  r.query_utime = d.query_utime;
  r.match_utime = d.match_utime;
  r.status = static_cast<int>(d.status);
  r.stage = d.stage;
  r.reason = d.reason;
  r.gate_distance = d.gate_distance;
  r.gate_radius = d.gate_radius;
  r.descriptor_distance = d.descriptor_distance;
  r.lcp_fraction = d.lcp_fraction;
  r.icp_residual = d.icp_residual;
  r.icp_fitness = d.icp_fitness;
  r.hungarian_consistency = d.hungarian_consistency;
  r.degeneracy = d.degeneracy;
  r.T_match_query = d.T_match_query;
  r.information = d.information;
  r.retrieval = d.retrieval;
  r.place_distance = d.place_distance;
  r.confirmed = d.confirmed;
  return r;
}

LoopDecision to_loop_decision(const LoopRecord& r) {
  LoopDecision d;
  d.event_id = r.event_id;
  d.query = r.query;
  d.match = r.match;
  d.query_utime = r.query_utime;
  d.match_utime = r.match_utime;
  d.status = r.status == static_cast<int>(LoopStatus::kAccepted)   ? LoopStatus::kAccepted
             : r.status == static_cast<int>(LoopStatus::kRejected) ? LoopStatus::kRejected
                                                                   : LoopStatus::kCandidate;
  d.stage = r.stage;
  d.reason = r.reason;
  d.gate_distance = r.gate_distance;
  d.gate_radius = r.gate_radius;
  d.descriptor_distance = r.descriptor_distance;
  d.lcp_fraction = r.lcp_fraction;
  d.icp_residual = r.icp_residual;
  d.icp_fitness = r.icp_fitness;
  d.hungarian_consistency = r.hungarian_consistency;
  d.degeneracy = r.degeneracy;
  d.T_match_query = r.T_match_query;
  d.information = r.information;
  d.retrieval = r.retrieval;
  d.place_distance = r.place_distance;
  d.confirmed = r.confirmed;
  return d;
}

CorrectionRecord to_correction_record(const CorrectionOutput& c) {
  CorrectionRecord r;
  r.revision = c.revision;
  r.loop_event_id = c.loop_event_id;
  r.method = c.method;
  r.T_map_odom = c.T_map_odom;
  r.keys = c.keys;
  r.T_map_sensor = c.T_map_sensor;
  r.corrector_state = encode_resume_state(c.resume_state);
  return r;
}

}  // namespace loopd
