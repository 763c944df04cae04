#pragma once
/// @file The detector's corrections as map store records (its loop decisions are stored as they are).
#include "loopd/records/store_records.hpp"
#include "loopd/pipeline/loop_detector.hpp"

namespace loopd {

CorrectionRecord to_correction_record(const CorrectionOutput& correction);

}  // namespace loopd
