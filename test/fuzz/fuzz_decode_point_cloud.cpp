// decode_any_point_cloud (what every scan reader uses): untrusted bytes are rejected with a reason, or decode and
// re-encode to the same bytes (a version-1 message, before per-point times: to the same bytes with today's fingerprint
// and num_point_times = 0 appended); decode_scan, the daemon's direct path, accepts the same and reads the same cloud.
#include "decode_round_trip.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  loopd::fuzz::decode_any_point_cloud_round_trip(data, size);
  return loopd::fuzz::decode_scan_agrees(data, size);
}
