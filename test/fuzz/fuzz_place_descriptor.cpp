// The map store's Scan Context bytes: untrusted bytes are refused with a reason (never a crash), or decode to a
// descriptor that encodes to exactly the input and whose distance to itself is 0.
#include "fuzz_support.hpp"
#include "loopd/descriptor/scan_context.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  const DecodedPlaceDescriptor d = decode_place_descriptor(data, size);
  fuzz::check(d.ok == d.error.empty(), "ok exactly when there is no error");
  if (!d.ok) {
    fuzz::check(d.error.rfind("place descriptor: ", 0) == 0, "the error names the blob");
    return 0;
  }
  fuzz::check(encode_place_descriptor(d.descriptor) == std::vector<std::uint8_t>(data, data + size), "bytes round-trip");
  const PlaceMatch self = place_distance(d.descriptor, d.descriptor);
  fuzz::check(self.ok && self.distance >= 0.f && self.distance <= 1.f, "distance in [0, 1]");
  for (float k : d.descriptor.ring_key) fuzz::check(k >= 0.f && k <= 1.f, "ring key in [0, 1]");
  return 0;
}
