#pragma once
// Decoder fuzz targets: decode_bounded either rejects the bytes with a reason, or decodes them, and then the message
// encodes back to exactly the input bytes (LCM's wire format has one encoding per message), so the fuzzer checks
// that what is accepted is decoded correctly, not only that nothing crashes.
#include <cstring>
#include <iterator>
#include <vector>

#include "bounded_decode.hpp"
#include "fuzz_support.hpp"
#include "message_convert.hpp"
#include "scan_decode.hpp"

namespace loopd::fuzz {

inline DecodeLimits fuzz_limits() {
  DecodeLimits limits;
  limits.max_points = 100000;  // small caps so a valid huge message cannot exhaust the fuzzer's memory
  limits.max_keyframes = 100000;
  return limits;
}

/// The outcome of a decode: a rejection says why and where; an accepted message encodes to exactly `expected`.
template <typename Msg>
int check_decoded(const DecodeResult& r, const Msg& msg, std::size_t size, const std::uint8_t* expected, std::size_t expected_size) {
  static const bool verbose = std::getenv("LOOPD_FUZZ_VERBOSE") != nullptr;  // to see what a reproducer does
  if (verbose) std::fprintf(stderr, "decode %zu bytes: %s (offset %zu)\n", size, r.ok ? "ok" : r.reason.c_str(), r.offset);
  if (!r.ok) {
    check(!r.reason.empty(), "a rejected message says why");
    check(r.offset <= size, "the failing offset lies inside the message");
    return 0;
  }
  const int encoded_size = msg.getEncodedSize();
  check(encoded_size >= 0 && static_cast<std::size_t>(encoded_size) == expected_size, "re-encoded size equals the input size");
  std::vector<std::uint8_t> out(expected_size);
  check(msg.encode(out.data(), 0, static_cast<int>(out.size())) == encoded_size, "the message encodes");
  for (std::size_t i = 0; i < expected_size; ++i) check(out[i] == expected[i], "the message encodes back to the input bytes");
  return 0;
}

template <typename Msg>
int decode_round_trip(const std::uint8_t* data, std::size_t size) {
  Msg msg;
  const DecodeResult r = decode_bounded(data, size, fuzz_limits(), &msg);
  return check_decoded(r, msg, size, data, size);
}

/// point_cloud_t of either layout (decode_any_point_cloud): today's re-encodes to the input; a version-1 message to
/// the input with today's fingerprint and num_point_times = 0 appended.
inline int decode_any_point_cloud_round_trip(const std::uint8_t* data, std::size_t size) {
  point_cloud_t msg;
  const DecodeResult r = decode_any_point_cloud(data, size, fuzz_limits(), &msg);
  std::int64_t hash = 0;
  for (std::size_t i = 0; i < 8 && i < size; ++i) hash = static_cast<std::int64_t>((static_cast<std::uint64_t>(hash) << 8) | data[i]);
  if (size < 8 || hash != kPointCloudV1Hash) return check_decoded(r, msg, size, data, size);
  std::vector<std::uint8_t> expected(data, data + size);
  const auto today = static_cast<std::uint64_t>(point_cloud_t::getHash());
  for (int i = 0; i < 8; ++i) expected[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(today >> (56 - 8 * i));
  expected.insert(expected.end(), 4, 0);
  return check_decoded(r, msg, size, expected.data(), expected.size());
}

/// decode_scan (the daemon's scan path) accepts exactly what decode_any_point_cloud and from_message accept together,
/// and reads the same cloud, bit for bit.
inline int decode_scan_agrees(const std::uint8_t* data, std::size_t size) {
  point_cloud_t msg;
  PointCloud via_message;
  std::string error;
  const bool accepted = decode_any_point_cloud(data, size, fuzz_limits(), &msg).ok && from_message(msg, &via_message, &error);
  DecodedScan scan;
  const DecodeResult r = decode_scan(data, size, fuzz_limits(), &scan);
  check(r.ok == accepted, "decode_scan accepts what decode_any_point_cloud and from_message accept");
  if (!r.ok) {
    check(!r.reason.empty() && r.offset <= size, "a rejected scan says why and where");
    return 0;
  }
  const auto same = [](const auto& a, const auto& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
  };
  check(scan.utime == msg.utime && scan.seq == msg.seq, "the stamp and sequence number agree");
  check(same(scan.cloud.points, via_message.points) && same(scan.cloud.intensity, via_message.intensity), "points and intensity agree");
  check(same(scan.cloud.ring, via_message.ring) && scan.cloud.num_rings == via_message.num_rings, "rings agree");
  check(same(scan.cloud.time, via_message.time), "per-point times agree");
  return 0;
}

/// loop_event_t of either layout (decode_any_loop_event, what the tools read logs with): today's re-encodes to the
/// input; a version-1 event to the input with today's fingerprint and the appended fields (sessions 0 and 0,
/// retrieval "gate", place_distance -1).
inline int decode_any_loop_event_round_trip(const std::uint8_t* data, std::size_t size) {
  constexpr std::uint64_t kLoopEventV1Hash = 0x0ca921302b50cd2aULL;  // bounded_decode.cpp
  loop_event_t msg;
  const DecodeResult r = decode_any_loop_event(data, size, fuzz_limits(), &msg);
  std::uint64_t hash = 0;
  for (std::size_t i = 0; i < 8 && i < size; ++i) hash = (hash << 8) | data[i];
  if (size < 8 || hash != kLoopEventV1Hash) return check_decoded(r, msg, size, data, size);
  std::vector<std::uint8_t> expected(data, data + size);
  const auto today = static_cast<std::uint64_t>(loop_event_t::getHash());
  for (int i = 0; i < 8; ++i) expected[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(today >> (56 - 8 * i));
  const std::uint8_t tail[] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 5, 'g', 'a', 't', 'e', 0, 0xbf, 0xf0, 0, 0, 0, 0, 0, 0};
  expected.insert(expected.end(), std::begin(tail), std::end(tail));
  return check_decoded(r, msg, size, expected.data(), expected.size());
}

}  // namespace loopd::fuzz
