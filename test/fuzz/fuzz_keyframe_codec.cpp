// The map store's keyframe codec: untrusted bytes are refused with a reason (never a crash, never an allocation the
// bytes cannot back), or decode to features that encode and decode again to the same blob.
#include "fuzz_support.hpp"
#include "loopd/store/keyframe_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  KeyframeCodecLimits limits;
  limits.max_payload = 64u << 20;  // stays inside libFuzzer's -rss_limit_mb
  const DecodedFeatures d = decode_features(data, size, limits);
  fuzz::check(d.ok == d.error.empty(), "ok exactly when there is no error");
  if (!d.ok) {
    fuzz::check(d.error.rfind("keyframe features: ", 0) == 0, "the error names the blob");
  } else {
    const std::vector<std::uint8_t> again = encode_features(d.features);
    const DecodedFeatures d2 = decode_features(again, limits);
    fuzz::check(d2.ok, "a decoded blob encodes to a blob that decodes");
    fuzz::check(encode_features(d2.features) == again, "encode(decode(encode(x))) == encode(x)");
  }
  const DecodedDescriptor desc = decode_descriptor(data, size);
  fuzz::check(desc.ok == desc.error.empty(), "descriptor: ok exactly when there is no error");
  if (desc.ok) {
    fuzz::check(static_cast<std::size_t>(desc.descriptor.size()) * 4 == size, "descriptor: 4 bytes a value");
    fuzz::check(encode_descriptor(desc.descriptor) == std::vector<std::uint8_t>(data, data + size), "descriptor: bytes round-trip");
  }
  return 0;
}
