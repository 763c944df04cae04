// decode_bounded for point_cloud_t: untrusted bytes are rejected with a reason or decode and re-encode to the same bytes.
#include "decode_round_trip.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return loopd::fuzz::decode_round_trip<loopd::point_cloud_t>(data, size);
}
