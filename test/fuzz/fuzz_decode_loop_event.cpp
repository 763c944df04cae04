// decode_any_loop_event for loop_event_t (today's layout and version 1, before sessions): untrusted bytes are
// rejected with a reason or decode and re-encode to the same bytes (a version-1 event: with the appended fields).
#include "decode_round_trip.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return loopd::fuzz::decode_any_loop_event_round_trip(data, size);
}
