#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace loopd::test {

/// @brief What a fault transform did to a drive log.
struct FaultResult {
  bool ok = false;
  std::string error;            ///< why the copy failed (file, event index)
  std::int64_t events_in = 0;   ///< events read from the input log
  std::int64_t events_out = 0;  ///< events written to the faulty copy
  std::int64_t affected = 0;    ///< messages the fault touched: dropped, removed, duplicated, swapped, re-stamped, replaced
};

/// @brief Drops each message on `channel` with probability `fraction` (seeded, deterministic). `affected` = dropped.
FaultResult drop_messages(const std::string& in, const std::string& out, const std::string& channel, double fraction, std::uint64_t seed);

/// @brief Removes every message on `channel` whose utime lies in [from_utime, to_utime). `affected` = removed.
FaultResult remove_window(const std::string& in, const std::string& out, const std::string& channel, std::int64_t from_utime, std::int64_t to_utime);

/// @brief A data clock step: every message (on every channel) whose utime is >= `from_utime` gets utime + `shift_us`.
///        The logger's event timestamps stay as they were (monotonic): the logger's own clock did not jump, the
///        publishers' did (a GPS/NTP time step). `affected` = re-stamped messages.
FaultResult shift_clock(const std::string& in, const std::string& out, std::int64_t from_utime, std::int64_t shift_us);

/// @brief Every message on one of `channels` is written twice in a row (same bytes, same timestamp), as a
///        publisher that sends twice or two bridges forwarding the same topic would. `affected` = duplicates added.
FaultResult duplicate_messages(const std::string& in, const std::string& out, const std::vector<std::string>& channels);

/// @brief Reorders messages as a network does: each message on `channel` is, with probability `fraction` (seeded),
///        swapped with the next message on the same channel (within `max_apart_us` of data time), so the newer one
///        arrives first. The events keep their positions' logger timestamps (monotonic). Swapped pairs never overlap.
///        `affected` = swapped pairs.
FaultResult swap_neighbours(const std::string& in, const std::string& out, const std::string& channel, double fraction, std::int64_t max_apart_us,
                            std::uint64_t seed);

/// @brief Each message on `channel` is delivered before the message on `ahead_of` with the same utime that precedes
///        it (a scan before its pose: two publishers, no order between them). Logger timestamps keep their
///        positions. `affected` = messages moved.
FaultResult deliver_before(const std::string& in, const std::string& out, const std::string& channel, const std::string& ahead_of);

/// @brief The sensor changed: every message on `channel` whose utime is >= `from_utime` is replaced by the message
///        of `other` (another drive over the same route, another lidar) with the same utime; messages with no
///        counterpart are left out. `affected` = replaced messages.
FaultResult splice_channel(const std::string& in, const std::string& other, const std::string& out, const std::string& channel,
                           std::int64_t from_utime);

/// @brief The odometry process restarted at `from_utime`: from the first pose on `channel` at or after it, poses are
///        T_reset^-1 * T (T_reset = that first pose), so the odometry starts again at identity, and their sequence
///        numbers start again at 0. Other channels (ground truth) unchanged. `affected` = re-expressed poses.
FaultResult reset_odometry(const std::string& in, const std::string& out, const std::string& channel, std::int64_t from_utime);

/// @brief utimes of the messages on `channel` in log order (from the first 8 bytes after the fingerprint).
std::vector<std::int64_t> channel_utimes(const std::string& path, const std::string& channel);

}  // namespace loopd::test
