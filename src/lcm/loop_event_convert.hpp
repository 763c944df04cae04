#pragma once
/// @file The one conversion between a loop decision (records/loop_decision.hpp) and its message, each way.
#include <cstdint>
#include <string>

#include <loopd/loop_event_t.hpp>

#include "loopd/records/loop_decision.hpp"

namespace loopd {

/// @brief loop_event_t for one decision; `utime` is the decision time [us]. The information matrix and the store's
/// flags (confirmed, published) do not travel.
loop_event_t to_message(const LoopDecision& decision, std::int64_t utime);

/// @brief The decision a loop_event_t carries (information zero, published true). False, with `error`, for a status
/// that is not one of STATUS_*.
bool from_message(const loop_event_t& msg, LoopDecision* decision, std::string* error);

}  // namespace loopd
