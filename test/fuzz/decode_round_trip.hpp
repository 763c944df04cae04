#pragma once
// Decoder fuzz targets: decode_bounded either rejects the bytes with a reason, or decodes them, and then the message
// encodes back to exactly the input bytes (LCM's wire format has one encoding per message), so the fuzzer checks
// that what is accepted is decoded correctly, not only that nothing crashes.
#include <vector>

#include "bounded_decode.hpp"
#include "fuzz_support.hpp"

namespace loopd::fuzz {

template <typename Msg>
int decode_round_trip(const std::uint8_t* data, std::size_t size) {
  DecodeLimits limits;
  limits.max_points = 100000;  // small caps so a valid huge message cannot exhaust the fuzzer's memory
  limits.max_keyframes = 100000;
  Msg msg;
  const DecodeResult r = decode_bounded(data, size, limits, &msg);
  static const bool verbose = std::getenv("LOOPD_FUZZ_VERBOSE") != nullptr;  // to see what a reproducer does
  if (verbose) std::fprintf(stderr, "decode %zu bytes: %s (offset %zu)\n", size, r.ok ? "ok" : r.reason.c_str(), r.offset);
  if (!r.ok) {
    check(!r.reason.empty(), "a rejected message says why");
    check(r.offset <= size, "the failing offset lies inside the message");
    return 0;
  }
  const int encoded_size = msg.getEncodedSize();
  check(encoded_size >= 0 && static_cast<std::size_t>(encoded_size) == size, "re-encoded size equals the input size");
  std::vector<std::uint8_t> out(size);
  check(msg.encode(out.data(), 0, static_cast<int>(out.size())) == encoded_size, "the message encodes");
  for (std::size_t i = 0; i < size; ++i) check(out[i] == data[i], "the message encodes back to the input bytes");
  return 0;
}

}  // namespace loopd::fuzz
