// .pcd point clouds (loopd's own parser): any byte string parses or fails with an error naming the file and the
// position; a parsed cloud never holds more points than the bytes can carry.
#include "fuzz_support.hpp"
#include "loopd/io/cloud_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  PointCloud cloud;
  std::string error;
  const std::string bytes = fuzz::as_string(data, size);
  if (parse_cloud_bytes(bytes, "fuzz.pcd", &cloud, &error)) {
    fuzz::check(cloud.intensity.empty() || cloud.has_intensity(), "intensity is empty or one per point");
    // Binary points take >= 3 bytes (x, y, z of 1 byte each); ascii points >= 6 (3 digits and 3 separators);
    // binary_compressed PCD can expand 88x at most.
    fuzz::check(cloud.size() <= size * 88, "no more points than the bytes can carry");
  } else {
    fuzz::check_error_names(error, "fuzz.pcd");
  }
  return 0;
}
