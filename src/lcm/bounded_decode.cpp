#include "bounded_decode.hpp"

#include "point_cloud_walk.hpp"
#include "wire_walker.hpp"

#include <cstring>
#include <exception>
#include <new>
#include <vector>

namespace loopd {
namespace {

// One layout function per message type, field by field as in lcmtypes/*.lcm (no hash: nested use).
void walk(WireWalker& w, const DecodeLimits&, const pose_t*) {
  w.skip("utime", 8);
  w.skip("seq", 8);
  w.skip("position", 8, 3);
  w.skip("orientation", 8, 4);
  w.skip("residual", 8);
  w.skip("has_covariance", 1);
  w.skip("covariance", 8, 36);
}

void walk(WireWalker& w, const DecodeLimits&, const imu_t*) {
  w.skip("utime", 8);
  w.skip("seq", 8);
  w.skip("angular_velocity", 8, 3);
  w.skip("linear_acceleration", 8, 3);
}

void walk(WireWalker& w, const DecodeLimits& limits, const point_cloud_t*) { walk_point_cloud(w, limits, true); }

/// loop_event_t up to ms_total: the whole of version 1 (before the sessions, `retrieval` and `place_distance`).
void walk_loop_event_v1(WireWalker& w, const DecodeLimits& limits) {
  w.skip("utime .. match_utime", 8, 6);
  w.skip("status", 1);
  w.string("stage", limits.max_string);
  w.string("reason", limits.max_string);
  w.skip("gate_distance .. degeneracy", 8, 8);
  w.skip("T_match_query", 8, 16);
  w.skip("ms_descriptor .. ms_total", 8, 5);
}

void walk(WireWalker& w, const DecodeLimits& limits, const loop_event_t*) {
  walk_loop_event_v1(w, limits);
  w.skip("query_session .. match_session", 4, 2);
  w.string("retrieval", limits.max_string);
  w.skip("place_distance", 8);
}

/// Fingerprint of loop_event_t version 1 (loopd output logs written before sessions).
constexpr std::int64_t kLoopEventV1Hash = 0x0ca921302b50cd2aLL;

void walk(WireWalker& w, const DecodeLimits&, const keyframe_pose_t*) {
  w.skip("id", 8);
  w.skip("utime", 8);
  w.skip("position", 8, 3);
  w.skip("orientation", 8, 4);
}
constexpr std::size_t kKeyframePoseBytes = 8 + 8 + 3 * 8 + 4 * 8;

void walk(WireWalker& w, const DecodeLimits&, const localization_t*) {
  w.skip("utime", 8);
  w.skip("session", 4);
  w.skip("keyframe_id", 8);
  w.skip("localized", 1);
  w.skip("localized_since_utime", 8);
  w.skip("loops_to_map", 4);
  w.skip("last_loop_utime", 8);
  w.skip("T_map_odom", 8, 16);
  w.skip("position", 8, 3);
  w.skip("orientation", 8, 4);
}

/// trajectory_t up to its keyframes: the whole of version 1 (before `full` and `total_keyframes` were appended).
/// Returns num_keyframes.
std::int64_t walk_trajectory_v1(WireWalker& w, const DecodeLimits& limits) {
  w.skip("utime", 8);
  w.skip("revision", 8);
  w.skip("loop_event_id", 8);
  w.string("method", limits.max_string);
  w.skip("T_map_odom", 8, 16);
  const std::int64_t n = w.length("num_keyframes", w.int32("num_keyframes"), limits.max_keyframes, kKeyframePoseBytes);
  w.skip("keyframes", kKeyframePoseBytes, static_cast<std::size_t>(n));
  return n;
}

/// trajectory_t up to total_keyframes: the whole of version 2 (before the sessions were appended).
std::int64_t walk_trajectory_v2(WireWalker& w, const DecodeLimits& limits) {
  const std::int64_t n = walk_trajectory_v1(w, limits);
  w.skip("full", 1);
  w.skip("total_keyframes", 8);
  return n;
}

void walk(WireWalker& w, const DecodeLimits&, const session_alignment_t*) {
  w.skip("session", 4);
  w.skip("anchored", 1);
  w.skip("T_map_session", 8, 16);
  w.skip("num_keyframes", 8);
}
constexpr std::size_t kSessionAlignmentBytes = 4 + 1 + 16 * 8 + 8;

void walk(WireWalker& w, const DecodeLimits& limits, const trajectory_t*) {
  const std::int64_t n = walk_trajectory_v2(w, limits);
  w.skip("keyframe_sessions", 4, static_cast<std::size_t>(n));
  const std::int64_t sessions = w.length("num_sessions", w.int32("num_sessions"), limits.max_sessions, kSessionAlignmentBytes);
  w.skip("sessions", kSessionAlignmentBytes, static_cast<std::size_t>(sessions));
}

/// Fingerprints of trajectory_t version 1 (before `full` and `total_keyframes`) and version 2 (before sessions).
constexpr std::int64_t kTrajectoryV1Hash = 0x5039562511ef5e3aLL;
constexpr std::int64_t kTrajectoryV2Hash = 0x32d603706da153a4LL;

void walk(WireWalker& w, const DecodeLimits& limits, const channel_stats_t*) {
  w.string("channel", limits.max_string);
  w.skip("received .. dropped", 8, 4);
}
constexpr std::size_t kMinChannelStatsBytes = 4 + 1 + 4 * 8;

void walk(WireWalker& w, const DecodeLimits& limits, const status_t*) {
  w.skip("utime", 8);
  w.skip("uptime_s", 8);
  const std::int64_t n = w.length("num_channels", w.int32("num_channels"), limits.max_channels, kMinChannelStatsBytes);
  for (std::int64_t i = 0; i < n && w.ok(); ++i) walk(w, limits, static_cast<const channel_stats_t*>(nullptr));
  w.skip("pending_scans", 4);
  w.skip("queue_depth", 4);
  w.skip("shed .. memory_bytes", 8, 7);
  w.string("device", limits.max_string);
  w.skip("scans_lost_estimate .. sensor_changes", 8, 4);
  w.string("map_path", limits.max_string);
  w.skip("map_bytes .. map_write_failures", 8, 3);
  w.string("map_error", limits.max_string);
  w.skip("keyframes_deskewed .. deskew_skipped", 8, 2);
  w.skip("map_write_retries .. events_not_republished", 8, 6);
}

/// The bytes of a message of an older layout with today's fingerprint in place of its own (the fields that the
/// newer layout appends are added by the caller).
std::vector<std::uint8_t> with_fingerprint(const void* data, std::size_t size, std::int64_t hash) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  std::vector<std::uint8_t> upgraded(bytes, bytes + size);
  for (int i = 0; i < 8; ++i) upgraded[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(hash) >> (56 - 8 * i));
  return upgraded;
}

void append_big_endian(std::vector<std::uint8_t>* bytes, std::uint64_t value, int width) {
  for (int i = width - 1; i >= 0; --i) bytes->push_back(static_cast<std::uint8_t>(value >> (8 * i)));
}

}  // namespace

template <typename Msg>
DecodeResult decode_bounded(const void* data, std::size_t size, const DecodeLimits& limits, Msg* out) {
  DecodeResult result;
  if (data == nullptr && size != 0) {
    result.reason = "no data";
    return result;
  }
  if (size > static_cast<std::size_t>(INT32_MAX)) {  // LCM's decoder takes an int length
    result.reason = "message of " + std::to_string(size) + " bytes is larger than LCM can decode";
    return result;
  }
  WireWalker w(data, size);
  w.fingerprint(Msg::getHash());
  walk(w, limits, static_cast<const Msg*>(nullptr));
  w.end();
  if (!w.ok()) {
    result.reason = w.error();
    result.offset = w.error_offset();
    return result;
  }
  // The layout is proven: LCM's decoder now allocates no more than the message holds. It still runs inside a try
  // block, so that nothing can escape into an LCM callback or the replay loop.
  try {
    *out = Msg();  // LCM's decoder leaves an array of declared length 0 as it was: start from an empty message
    const int used = out->decode(data, 0, static_cast<int>(size));
    if (used != static_cast<int>(size)) {
      result.reason = "LCM's decoder refused the message after the layout check (" + std::to_string(used) + ")";
      return result;
    }
  } catch (const std::bad_alloc&) {
    result.reason = "out of memory while decoding";
    return result;
  } catch (const std::exception& e) {
    result.reason = std::string("decoder error: ") + e.what();
    return result;
  }
  result.ok = true;
  return result;
}

template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, point_cloud_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, pose_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, imu_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, loop_event_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, keyframe_pose_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, localization_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, trajectory_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, session_alignment_t*);

namespace {
/// @brief Proves a message of an older layout (fingerprint `hash`, fields walked by `walk`) before it is upgraded;
///        the result is ok when every byte is where that layout puts it.
template <typename Walk>
DecodeResult prove_old_layout(const void* data, std::size_t size, std::int64_t hash, const Walk& walk) {
  DecodeResult result;
  if (data == nullptr || size < 8) {
    result.reason = "no fingerprint";
    return result;
  }
  WireWalker w(data, size);
  w.fingerprint(hash);
  walk(w);
  w.end();
  result.ok = w.ok();
  result.reason = w.error();
  result.offset = w.error_offset();
  return result;
}
}  // namespace

namespace {
/// @brief num_keyframes of a proven trajectory_t of version 1 or 2 (the same header).
std::int32_t old_trajectory_keyframes(const void* data, std::size_t size, const DecodeLimits& limits) {
  WireWalker header(data, size);
  header.skip("fingerprint .. loop_event_id", 8, 4);
  header.string("method", limits.max_string);
  header.skip("T_map_odom", 8, 16);
  return header.int32("num_keyframes");
}

/// @brief Appends what version 3 adds to version 2: every keyframe in session 0, no session alignments.
void append_trajectory_v3_fields(std::vector<std::uint8_t>* bytes, std::int32_t num_keyframes) {
  bytes->insert(bytes->end(), static_cast<std::size_t>(num_keyframes) * 4, 0);
  append_big_endian(bytes, 0, 4);
}
}  // namespace

DecodeResult decode_trajectory_v1(const void* data, std::size_t size, const DecodeLimits& limits, trajectory_t* out) {
  DecodeResult proof = prove_old_layout(data, size, kTrajectoryV1Hash, [&](WireWalker& w) { walk_trajectory_v1(w, limits); });
  if (!proof.ok) return proof;
  // Today's layout of the same message: the new fingerprint, the version-1 fields, full = true and
  // total_keyframes = num_keyframes (a version-1 message held every keyframe), then version 3's sessions.
  const std::int32_t num = old_trajectory_keyframes(data, size, limits);
  std::vector<std::uint8_t> upgraded = with_fingerprint(data, size, trajectory_t::getHash());
  upgraded.push_back(1);
  append_big_endian(&upgraded, static_cast<std::uint64_t>(num), 8);
  append_trajectory_v3_fields(&upgraded, num);
  return decode_bounded(upgraded.data(), upgraded.size(), limits, out);
}

DecodeResult decode_trajectory_v2(const void* data, std::size_t size, const DecodeLimits& limits, trajectory_t* out) {
  DecodeResult proof = prove_old_layout(data, size, kTrajectoryV2Hash, [&](WireWalker& w) { walk_trajectory_v2(w, limits); });
  if (!proof.ok) return proof;
  std::vector<std::uint8_t> upgraded = with_fingerprint(data, size, trajectory_t::getHash());
  append_trajectory_v3_fields(&upgraded, old_trajectory_keyframes(data, size, limits));
  return decode_bounded(upgraded.data(), upgraded.size(), limits, out);
}

DecodeResult decode_loop_event_v1(const void* data, std::size_t size, const DecodeLimits& limits, loop_event_t* out) {
  DecodeResult proof = prove_old_layout(data, size, kLoopEventV1Hash, [&](WireWalker& w) { walk_loop_event_v1(w, limits); });
  if (!proof.ok) return proof;
  // Sessions 0 and 0, retrieval "gate" (the only one before), place_distance -1.
  std::vector<std::uint8_t> upgraded = with_fingerprint(data, size, loop_event_t::getHash());
  append_big_endian(&upgraded, 0, 8);
  const std::string gate = "gate";
  append_big_endian(&upgraded, gate.size() + 1, 4);
  upgraded.insert(upgraded.end(), gate.begin(), gate.end());
  upgraded.push_back(0);
  double minus_one = -1.0;
  std::uint64_t bits = 0;
  std::memcpy(&bits, &minus_one, sizeof bits);
  append_big_endian(&upgraded, bits, 8);
  return decode_bounded(upgraded.data(), upgraded.size(), limits, out);
}

DecodeResult decode_any_loop_event(const void* data, std::size_t size, const DecodeLimits& limits, loop_event_t* out) {
  WireWalker w(data, data == nullptr ? 0 : size);
  const std::int64_t hash = w.int64("fingerprint");
  if (w.ok() && hash == kLoopEventV1Hash) return decode_loop_event_v1(data, size, limits, out);
  return decode_bounded(data, size, limits, out);
}

DecodeResult decode_point_cloud_v1(const void* data, std::size_t size, const DecodeLimits& limits, point_cloud_t* out) {
  DecodeResult proof = prove_old_layout(data, size, kPointCloudV1Hash, [&](WireWalker& w) { walk_point_cloud(w, limits, false); });
  if (!proof.ok) return proof;
  // Today's layout of the same message: the new fingerprint, the version-1 fields, num_point_times = 0 (no times).
  std::vector<std::uint8_t> upgraded = with_fingerprint(data, size, point_cloud_t::getHash());
  append_big_endian(&upgraded, 0, 4);
  return decode_bounded(upgraded.data(), upgraded.size(), limits, out);
}

DecodeResult decode_any_point_cloud(const void* data, std::size_t size, const DecodeLimits& limits, point_cloud_t* out) {
  WireWalker w(data, data == nullptr ? 0 : size);
  const std::int64_t hash = w.int64("fingerprint");
  if (w.ok() && hash == kPointCloudV1Hash) return decode_point_cloud_v1(data, size, limits, out);
  return decode_bounded(data, size, limits, out);
}
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, channel_stats_t*);
template DecodeResult decode_bounded(const void*, std::size_t, const DecodeLimits&, status_t*);

}  // namespace loopd
