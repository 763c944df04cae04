#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "converter.hpp"

namespace loopd::bag2lcm {

/// @brief The tables bag2lcm prints at the end (topics, skipped messages by reason, the conversion's figures).
std::string report_table(const Report& r);
/// @brief The --json object (keys in docs/recordings.md).
nlohmann::json report_json(const Report& r);

}  // namespace loopd::bag2lcm
