#pragma once
/// @file The detector's decisions and corrections as map store records, and back.
#include "loopd/map/map_records.hpp"
#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

LoopRecord to_loop_record(const LoopDecision& decision);
LoopDecision to_loop_decision(const LoopRecord& record);
CorrectionRecord to_correction_record(const CorrectionOutput& correction);

}  // namespace loopd
