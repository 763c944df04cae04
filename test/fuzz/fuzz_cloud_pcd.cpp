// .pcd point clouds (loopd's own parser): any byte string parses or fails with an error naming the file and the
// position; a parsed cloud never holds more points than the bytes can carry.
#include "fuzz_support.hpp"
#include "loopd/io/cloud_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace loopd;
  const std::string bytes = fuzz::as_string(data, size);
  const CloudFile file = parse_cloud_bytes(bytes, "fuzz.pcd");
  const PointCloud& cloud = file.cloud;
  const std::string& error = file.error;
  fuzz::check(file.ok == error.empty(), "ok exactly when there is no error");
  if (!file.ok) fuzz::check(cloud.empty(), "a failed read hands out no points");
  if (file.ok) {
    fuzz::check(cloud.intensity.empty() || cloud.has_intensity(), "intensity is empty or one per point");
    // Binary points take >= 3 bytes (x, y, z of 1 byte each); ascii points >= 6 (3 digits and 3 separators);
    // binary_compressed PCD can expand 88x at most.
    fuzz::check(cloud.size() <= size * 88, "no more points than the bytes can carry");
  } else {
    fuzz::check_error_names(error, "fuzz.pcd");
  }
  return 0;
}
