#include "loopd/runtime/map_records_convert.hpp"

#include "loopd/correction/loop_corrector.hpp"

namespace loopd {

CorrectionRecord to_correction_record(const CorrectionOutput& c) {
  CorrectionRecord r;
  r.revision = c.revision;
  r.loop_event_id = c.loop_event_id;
  r.method = c.method;
  r.T_map_odom = c.T_map_odom;
  r.keys = c.keys;
  r.T_map_sensor = c.T_map_sensor;
  r.corrector_state = encode_resume_state(c.resume_state);
  r.ledger_seq = c.ledger_seq;
  return r;
}

}  // namespace loopd
