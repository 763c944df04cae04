// The map cloud codec: untrusted bytes are refused with a reason (never a crash, never an allocation the header, checked
// against the bytes, does not allow), or decode to a cloud that encodes and decodes again to the same points.
#include "fuzz_support.hpp"
#include "loopd/store/map_cloud_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  MapCloudCodecLimits limits;
  limits.max_payload = 64u << 20;  // stays inside libFuzzer's -rss_limit_mb
  const DecodedMapCloud d = decode_map_cloud(data, size, limits);
  fuzz::check(d.ok == d.error.empty(), "ok exactly when there is no error");
  if (!d.ok) {
    fuzz::check(d.error.rfind("map cloud: ", 0) == 0, "the error names the blob");
    return 0;
  }
  fuzz::check(map_cloud_blob_points(data, size) == d.cloud.size(), "the header's count is the decoded count");
  const DecodedMapCloud again = decode_map_cloud(encode_map_cloud(d.cloud, d.quantum), limits);
  fuzz::check(again.ok && again.cloud.size() == d.cloud.size(), "a decoded cloud encodes to a blob that decodes to as many points");
  return 0;
}
