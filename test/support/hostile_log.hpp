#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace loopd::test {

/// @brief The crafted LIDAR_SCAN payloads that stopped loopd before bounded decoding: the right fingerprint followed
///        by random bytes; ~60 bytes whose num_points is -1; the same with num_points = 2^31 - 1.
std::vector<std::vector<std::uint8_t>> crafted_scan_payloads();

/// @brief Copies an lcm-logger file, inserting the crafted scans (on `scan_channel`, stamped like the event before)
///        after event `after_event`, and, when `damage_header`, a damaged event (a sync word with an impossible data
///        length) after event 2 * after_event. Returns the number of crafted messages inserted, -1 on an I/O error.
int copy_with_crafted_scans(const std::string& in, const std::string& out, const std::string& scan_channel, int after_event, bool damage_header);

}  // namespace loopd::test
